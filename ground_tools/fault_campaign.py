"""The fault campaign (docs/faults.md), shared by tests/test_faults.py and benchmarks/bench_faults.py: seeded
malformed datagrams, a flight over a faulty plant link, junk at every port while the vehicle hovers, and reading
the kept files back. Every process started here is killed by its PID when the function returns."""

from __future__ import annotations

import math
import random
import signal
import socket
import subprocess
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import ParameterStore
from tiltrotor_sitl._children import Stream, start, stop
from tiltrotor_sitl._commands import AutopilotCommand, SimCommand, Zenoh, free_link_ports
from tiltrotor_sitl._free_ports import free_udp_port
from tiltrotor_sitl.fault_proxy import FaultProxy, Faults
from transport.flight_log import DOWN, PITCH, ROLL, VN, VN_SP, read_flight_log
from transport.mavlink import Link
from transport.mavlink import mavlink as M
from transport.ports import LOOPBACK

OVERSIZED_BYTES = 60_000  # above the autopilot's MAX_DATAGRAM_BYTES, below the loopback's 65 507
KINDS = ("random", "truncated", "bad_crc", "oversized", "absurd", "wrong_target")
VELOCITY_MASK = 0x9C7


def _frames(link: Link, sysid: int) -> tuple[list[bytes], list[bytes]]:
    """(valid frames with absurd values for `sysid`, valid frames for another system or component)."""
    mav, nan, inf = link.mav, math.nan, math.inf
    absurd = [
        mav.set_position_target_local_ned_encode(0, sysid, 1, M.MAV_FRAME_LOCAL_NED, VELOCITY_MASK, 0, 0, 0, nan, inf,
                                                 -inf, 0, 0, 0, 0, 0),
        mav.set_position_target_local_ned_encode(0, sysid, 1, M.MAV_FRAME_LOCAL_NED, 0, nan, 1e30, -1e30, nan, 0, 0,
                                                 inf, 0, 0, nan, inf),
        mav.command_long_encode(sysid, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, nan, nan, 0, 0, 0, 0, 0),
        mav.command_long_encode(sysid, 1, M.MAV_CMD_DO_SET_MODE, 0, inf, -1e9, nan, 0, 0, 0, 0),
        mav.command_long_encode(sysid, 1, M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, nan, nan, nan, 1e38),
        mav.command_long_encode(sysid, 1, M.MAV_CMD_INJECT_FAILURE, 0, 101, 1, 0, 0, 0, 0, 0),  # SYS_FAILURE_EN 0
        mav.param_set_encode(sysid, 1, b"MPC_XY_VEL_MAX", nan, M.MAV_PARAM_TYPE_REAL32),
        mav.param_set_encode(sysid, 1, b"\xff\x01junk\x00\x07", 1e38, 77),
        mav.param_request_read_encode(sysid, 1, b"", 32767),
        mav.mission_count_encode(sysid, 1, 65535, 0),
        mav.mission_request_int_encode(sysid, 1, 65535, 0),
        mav.command_int_encode(sysid, 1, M.MAV_FRAME_GLOBAL_INT, M.MAV_CMD_DO_REPOSITION, 0, 0, nan, inf, 0, nan,
                               2**31 - 1, -(2**31), nan),
    ]  # fmt: skip
    other = sysid + 76
    wrong = [
        mav.command_long_encode(other, 1, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 21196, 0, 0, 0, 0, 0),  # force disarm
        mav.command_long_encode(sysid, 99, M.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 21196, 0, 0, 0, 0, 0),
        mav.set_position_target_local_ned_encode(0, other, 1, M.MAV_FRAME_LOCAL_NED, VELOCITY_MASK, 0, 0, 0, 30, 0, 30,
                                                 0, 0, 0, 0, 0),
        mav.param_set_encode(other, 1, b"COM_OF_LOSS_T", 60.0, M.MAV_PARAM_TYPE_REAL32),
        mav.mission_clear_all_encode(other, 1, M.MAV_MISSION_TYPE_ALL),
    ]  # fmt: skip
    return [link.pack(m) for m in absurd], [link.pack(m) for m in wrong]


def malformed_datagrams(seed: int, count: int, sysid: int = 1) -> Iterator[tuple[str, bytes]]:
    """`count` seeded malformed datagrams (kind, bytes), the kinds in KINDS taken in turn: random bytes, a valid
    frame cut short, a frame with a bad CRC, an oversized datagram, valid frames with absurd values (NaN/Inf
    set-points, huge counts and indices, non-integer command parameters) and valid frames for another target."""
    rng = random.Random(seed)
    link = Link(255, 190)
    absurd, wrong = _frames(link, sysid)
    good = absurd + wrong + [link.pack(link.mav.heartbeat_encode(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0))]
    for i in range(count):
        kind = KINDS[i % len(KINDS)]
        if kind == "random":
            data = rng.randbytes(rng.randint(1, 300))
        elif kind == "truncated":
            frame = rng.choice(good)
            data = frame[: rng.randint(1, len(frame) - 1)]
        elif kind == "bad_crc":
            frame = bytearray(rng.choice(good))
            frame[rng.randrange(10, len(frame))] ^= 1 << rng.randrange(8)  # payload or CRC: the CRC no longer fits
            data = bytes(frame)
        elif kind == "oversized":
            data = rng.randbytes(16) + bytes(OVERSIZED_BYTES)
        elif kind == "absurd":
            data = rng.choice(absurd)
        else:
            data = rng.choice(wrong)
        yield kind, data


@dataclass
class Injected:
    """What was sent to one port."""

    port: int
    sent: Counter = field(default_factory=Counter)
    send_failed: int = 0

    @property
    def total(self) -> int:
        return sum(self.sent.values())


def send_malformed(targets: dict[str, int], per_port: int, seed: int, burst: int = 6,
                   pause_s: float = 0.002) -> dict[str, Injected]:  # fmt: skip
    """`per_port` malformed datagrams to each port (name -> port), interleaved, in bursts of `burst` with a pause
    between (so the receivers' socket buffers are not simply overrun); a full buffer is counted, not an error."""
    injected = {name: Injected(port) for name, port in targets.items()}
    sources = {name: malformed_datagrams(seed + i, per_port) for i, name in enumerate(targets)}
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for i in range(per_port):
            for name, port in targets.items():
                kind, data = next(sources[name])
                try:
                    sock.sendto(data, (LOOPBACK, port))
                    injected[name].sent[kind] += 1
                except OSError:
                    injected[name].send_failed += 1
            if i % burst == burst - 1:
                time.sleep(pause_s)
    return injected


# ---- processes -------------------------------------------------------------------------------------------------
@dataclass
class FlightFigures:
    """A flight read back from the autopilot's 100 Hz log."""

    seconds: float
    vx_rmse: float  # m/s, north velocity against its set-point
    altitude_deviation: float  # m, largest |altitude - start altitude|
    roll_max_deg: float
    pitch_max_deg: float

    @classmethod
    def of_log(cls, log: Path, skip_s: float = 0.0) -> FlightFigures:
        flight = read_flight_log(log)
        c = flight.columns
        t = c["t"]
        keep = t >= t[0] + skip_s
        down = c[DOWN][keep]
        return cls(float(t[-1] - t[0]), float(np.sqrt(np.mean((c[VN][keep] - c[VN_SP][keep]) ** 2))),
                   float(np.max(np.abs(down - c[DOWN][0]))), float(np.degrees(np.max(np.abs(c[ROLL][keep])))),
                   float(np.degrees(np.max(np.abs(c[PITCH][keep])))))  # fmt: skip


@dataclass
class PlantLinkRun:
    figures: FlightFigures
    plant: dict
    autopilot_rc: int
    proxy: dict[str, dict[str, int]] | None


def fly_plant_link(folder: Path, name: str, faults: Faults | None, *, duration_s: float, seed: int = 1,
                   profile: str = "accel", controller: str = "pid", spawn_alt: float = 50.0,
                   lockstep_timeout_s: float = 0.02) -> PlantLinkRun:  # fmt: skip
    """The internal `profile` flown in lockstep for `duration_s` simulated seconds, the plant link through a fault
    proxy (None: direct). The autopilot's --sim-port is the proxy's port; the plant binds the proxy's socket for
    that autopilot as its peer after the handshake (which the proxy's faults may delay, never break)."""
    port, log = free_udp_port(), folder / f"{name}.csv"
    sim = SimCommand(port=port, spawn_alt=spawn_alt, duration_s=duration_s, lockstep_timeout_s=lockstep_timeout_s,
                     summary=True, zenoh=Zenoh.off())  # fmt: skip
    proxy = FaultProxy(port, faults, seed=seed).start() if faults is not None else None
    autopilot = AutopilotCommand(
        sim_port=proxy.port if proxy is not None else port,
        links=free_link_ports(),
        spawn_alt=spawn_alt,
        profile=profile,
        duration_s=duration_s,
        controller=controller,
        zenoh=Zenoh.off(),
        quiet=True,
        log=log,
        params=folder / f"{name}.params.json",
    )
    plant = start("vtol-sim", sim.argv(), stdout=Stream.CAPTURE, stderr=Stream.DISCARD)
    pilot = start("vtol-autopilot", autopilot.argv(), stdout=Stream.DISCARD, stderr=Stream.DISCARD)
    try:
        plant.wait(600)
        try:  # the plant stops after its last state; if the proxy lost that one, the autopilot waits for more
            pilot.wait(5)
        except subprocess.TimeoutExpired:
            pilot.send_signal(signal.SIGTERM)
            pilot.wait(30)
    finally:
        stop([pilot, plant], signal.SIGKILL)
        if proxy is not None:
            proxy.stop()
    return PlantLinkRun(FlightFigures.of_log(log), plant.summary(), pilot.wait(),
                        proxy.summary() if proxy is not None else None)  # fmt: skip


@dataclass
class JunkRun:
    injected: dict[str, Injected]
    figures: FlightFigures
    autopilot: dict
    plant: dict
    autopilot_rc: int | None
    plant_rc: int | None
    crashed: list[str]
    files_intact: bool
    stderr: str


def junk_while_hovering(folder: Path, per_port: int, *, seed: int = 7, spawn_alt: float = 50.0,
                        speed: float = 1.0) -> JunkRun:  # fmt: skip
    """Hover (spawned at `spawn_alt`, Hold, paced x`speed`) while `per_port` malformed datagrams go to each of the
    plant port, the GCS port and the API port; then SIGTERM both processes and read their summaries, the flight log
    and the kept files."""
    port, links = free_udp_port(), free_link_ports()
    log, params = folder / "junk.csv", folder / "junk.params.json"
    sim = SimCommand(port=port, spawn_alt=spawn_alt, realtime_speed=speed, summary=True, zenoh=Zenoh.off())
    autopilot = AutopilotCommand(sim_port=port, links=links, spawn_alt=spawn_alt, controller="pid", zenoh=Zenoh.off(),
                                 log=log, params=params, summary=True)  # fmt: skip
    plant = start("vtol-sim", sim.argv(), stdout=Stream.CAPTURE, stderr=Stream.DISCARD)
    pilot = start("vtol-autopilot", autopilot.argv(), stdout=Stream.CAPTURE, stderr=folder / "junk.autopilot.stderr",
                  env={"PYTHONUNBUFFERED": "1"})  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while not (log.exists() and log.stat().st_size > 2000):  # the autopilot has the plant and flies
            if time.monotonic() > deadline or pilot.poll() is not None:
                raise RuntimeError("the autopilot never started flying")
            time.sleep(0.05)
        time.sleep(1.0)
        targets = {"plant": port, "gcs": links.gcs_bind, "api": links.api_bind}
        injected = send_malformed(targets, per_port, seed)
        time.sleep(1.0)
        crashed = [p.name for p in (pilot, plant) if p.poll() is not None]
        for p in (pilot, plant):
            p.send_signal(signal.SIGTERM)
        pilot.wait(60)
        plant.wait(60)
    finally:
        stop([pilot, plant], signal.SIGKILL)
    return JunkRun(injected, FlightFigures.of_log(log), pilot.summary(), plant.summary(), pilot.returncode,
                   plant.returncode, crashed, files_intact(params, None), pilot.stderr_text())  # fmt: skip


def files_intact(params: Path, missions: Path | None) -> bool:
    """The parameter file (and mission file) load with the project's own loaders (a missing file is all defaults,
    which counts as intact only if nothing was ever written: the caller knows)."""
    ParameterStore(path=params).load()
    if missions is not None:
        MissionStore(path=missions).load()
    return True
