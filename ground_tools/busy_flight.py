"""An interactive session on a busy machine (docs/faults.md, a busy machine): a pymavlink script flies an Offboard
velocity profile in real time against a vehicle from the public API, optionally with another program (a lockstep
scenario) running beside it on the same cores, and the tracking error, the PID fall-backs and the speed the
simulation achieved are measured. Used by tests/test_busy_machine.py and benchmarks/bench_busy.py.

The script follows the vehicle's clock (time_boot_ms): a set-point is the profile at the simulated time the
vehicle last reported, as a script should when the simulation may run slower than the wall clock.
"""

from __future__ import annotations

import math
import os
import signal
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pymavlink import mavutil

from tiltrotor_sitl import Controller, ProcessOptions, Vehicle

M = mavutil.mavlink
# (t s, v_north, v_east, v_down m/s): multirotor speeds in every direction, linear between the knots
PROFILE = np.array([
    (0, 0, 0, 0), (2, 0, 0, 0), (6, 4, 0, 0), (12, 4, 0, 0), (16, 0, 3, 0), (22, 0, 3, -1), (26, -3, 0, 0),
    (32, -3, 0, 1), (36, 0, 0, 0), (40, 0, 0, 0),
], dtype=float)  # fmt: skip
VELOCITY_ONLY = 0b110111000111
SETPOINT_PERIOD_S = 0.02  # wall seconds between set-points (50 Hz)
SETTLE_S = 2.0  # simulated seconds before the error counts (entering Offboard)
OFFBOARD_MAIN_MODE = 6


def setpoint_at(t: float, duration_s: float) -> np.ndarray:
    """The profile's velocity (NED, m/s) at t seconds, the 40 s profile squeezed into `duration_s`."""
    u = t * PROFILE[-1, 0] / duration_s
    return np.array([np.interp(u, PROFILE[:, 0], PROFILE[:, axis]) for axis in (1, 2, 3)])


@dataclass(frozen=True)
class BusyFlight:
    """One flight's outcome."""

    rms_ned: tuple[float, float, float]  # m/s, velocity minus set-point, after SETTLE_S
    samples: int  # LOCAL_POSITION_NED messages used
    fell_back_to_pid: bool
    offboard_left: bool  # the vehicle left Offboard during the profile (a failsafe)
    real_time_factor: float  # what the plant achieved: simulated / wall seconds
    slowdowns: int  # times the plant moved its schedule because the autopilot fell behind
    wall_s: float
    beside_ran_throughout: bool | None  # the program beside was still running at the end (None: none given)


def start_beside(command: Sequence[str], folder: Path) -> subprocess.Popen:
    log = open(folder / "beside.log", "w")  # noqa: SIM115 (closed with the process, in stop_beside)
    return subprocess.Popen(list(command), stdout=log, stderr=subprocess.STDOUT, start_new_session=True, cwd=folder)


def stop_beside(process: subprocess.Popen) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    if process.stdout is not None:
        process.stdout.close()


def fly_profile(folder: Path, duration_s: float = 40.0, controller: Controller = "mpc",
                beside: Sequence[str] | None = None) -> BusyFlight:  # fmt: skip
    """Fly the profile (scaled to `duration_s`) hovering at 50 m, `beside` (a command line) running meanwhile."""
    folder.mkdir(parents=True, exist_ok=True)
    other = start_beside(beside, folder) if beside else None
    errors: list[np.ndarray] = []
    left = False
    started = time.monotonic()
    try:
        with Vehicle(
            controller=controller,
            spawn_alt=50.0,
            speed=1.0,
            truth=False,
            folder=folder / "vehicle",
            processes=ProcessOptions(summary=True),
        ) as vehicle:
            link = mavutil.mavlink_connection(vehicle.pymavlink, source_system=255, source_component=190)
            try:
                errors, left = _fly(link, vehicle.sysid, duration_s)
            finally:
                link.close()
        autopilot, plant = vehicle.summary("vtol-autopilot"), vehicle.summary("vtol-sim")
        beside_ran = None if other is None else other.poll() is None
    finally:
        if other is not None:
            stop_beside(other)
    error = np.array(errors)
    rms = tuple(float(math.sqrt(np.mean(error[:, axis] ** 2))) for axis in range(3))
    return BusyFlight(
        rms,
        len(errors),
        bool(autopilot["controller"].get("fell_back_to_pid", False)),
        left,
        float(plant["real_time_factor"]),
        int(plant["slowdowns"]),
        time.monotonic() - started,
        beside_ran,
    )


def _fly(link: mavutil.mavfile, target: int, duration_s: float) -> tuple[list[np.ndarray], bool]:
    heartbeat = link.wait_heartbeat(timeout=60)
    if heartbeat is None:
        raise RuntimeError("no HEARTBEAT from the vehicle")
    link.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    sim_ms, start_ms, in_offboard, left = None, None, False, False
    errors: list[np.ndarray] = []
    next_setpoint = next_heartbeat = next_mode_request = time.monotonic()
    while True:
        message = link.recv_match(blocking=True, timeout=SETPOINT_PERIOD_S / 2)
        now = time.monotonic()
        if message is not None:
            kind = message.get_type()
            if kind in ("LOCAL_POSITION_NED", "ATTITUDE", "GLOBAL_POSITION_INT", "SYSTEM_TIME"):
                sim_ms = message.time_boot_ms
            if kind == "HEARTBEAT" and message.get_srcComponent() == 1:
                offboard = (message.custom_mode >> 16) & 0xFF == OFFBOARD_MAIN_MODE
                left = left or (in_offboard and not offboard)
                in_offboard = in_offboard or offboard
            if kind == "LOCAL_POSITION_NED" and start_ms is not None and in_offboard:
                t = (message.time_boot_ms - start_ms) / 1000.0
                if t >= duration_s:
                    return errors, left
                if t >= SETTLE_S:
                    measured = np.array([message.vx, message.vy, message.vz])
                    errors.append(measured - setpoint_at(t, duration_s))
        if sim_ms is None:
            continue
        if start_ms is None:
            start_ms = sim_ms + 500  # half a second of set-points before Offboard, as PX4 asks
        if now >= next_setpoint:
            next_setpoint = now + SETPOINT_PERIOD_S
            vn, ve, vd = setpoint_at(max(0.0, (sim_ms - start_ms) / 1000.0), duration_s)
            link.mav.set_position_target_local_ned_send(sim_ms, target, 1, M.MAV_FRAME_LOCAL_NED, VELOCITY_ONLY,
                                                        0, 0, 0, vn, ve, vd, 0, 0, 0, 0, 0)  # fmt: skip
        if now >= next_heartbeat:
            next_heartbeat = now + 1.0
            link.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        if not in_offboard and sim_ms >= start_ms and now >= next_mode_request:
            next_mode_request = now + 0.5  # until the HEARTBEAT says Offboard (a lost command is asked again)
            link.mav.command_long_send(target, 1, M.MAV_CMD_DO_SET_MODE, 0, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                       OFFBOARD_MAIN_MODE, 0, 0, 0, 0, 0)  # fmt: skip
