"""The command lines of the two processes, `vtol-sim` (the plant) and `vtol-autopilot`, built from typed
descriptions; the ports to put them on (an instance's or free ones), a fleet's homes, and the command line and
environment of a run that must repeat bit for bit (tiltrotor_sitl/_children.py starts them).

A description's defaults are the program's own: a field left alone adds nothing to the command line. Each
`argv()` runs the program's module with this interpreter ([sys.executable, "-m", "sim_bridge" | "autopilot",
...]), so it works in a virtual environment whose scripts are not on PATH.
"""

from __future__ import annotations

import functools
import os
import platform
import shutil
import socket
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from autopilot.topics.controller_kind import ControllerKind
from tiltrotor_sitl._free_ports import lease_ports
from transport.geodesy import Home, LocalGeodetic, home_from
from transport.ports import Ports, zenoh_endpoint
from transport.wind import Wind

FLEET_SPACING_M = 5.0  # vehicles of a fleet stand this far apart, in a row to the east
SIM_MODULE = "sim_bridge"
AUTOPILOT_MODULE = "autopilot"
Controller = ControllerKind  # "mpc" (the unified MPC, the PID its back-up) or "pid" (the PID baseline alone)


def python_module(module: str, args: list[str]) -> list[str]:
    """[this interpreter, -m, module, *args]."""
    return [sys.executable, "-m", module, *args]


def _option(name: str, value: object | None) -> list[str]:
    """[name, str(value)], or nothing for None."""
    return [] if value is None else [name, str(value)]


def _flag(name: str, on: bool) -> list[str]:
    return [name] if on else []


def _home(home: Home | None) -> list[str]:
    # "--home=" keeps a southern or western home (a leading minus) from being read as an option
    return [] if home is None else [f"--home={home.lat!r},{home.lon!r},{home.alt!r}"]


def _wind(wind_ned: tuple[float, float, float] | None) -> list[str]:
    return [] if wind_ned is None else ["--wind=" + ",".join(repr(float(v)) for v in wind_ned)]  # (as _home)


def plant_wind(wind: Wind | None) -> dict[str, Any]:
    """SimCommand's wind fields for `wind` (None: the plant's default, no wind)."""
    if wind is None:
        return {}
    north, east = wind.velocity_ne
    return {"wind_ned": (north, east, 0.0), "wind_turbulence": wind.turbulence, "wind_seed": wind.seed}


def fleet_home(index: int, home: Home | None = None, spacing_m: float = FLEET_SPACING_M) -> Home:
    """The home of a fleet's `index`-th vehicle: `spacing_m` metres east of the previous one (the first at `home`,
    default PX4's home or PX4_HOME_LAT/LON/ALT, as the processes read it). Plant and autopilot of a vehicle are
    given the same home, so each vehicle's local frame starts at its own spot, and ground stations see the vehicles
    side by side."""
    origin = home if home is not None else home_from(None, os.environ)
    lat, lon, alt = LocalGeodetic(origin).to_geodetic(0.0, index * spacing_m, 0.0)
    return Home(lat, lon, alt)


def deterministic_environment() -> dict[str, str]:
    """The environment for runs that must repeat bit for bit (lockstep scenarios and flights): this one with
    PYTHONHASHSEED fixed, so Python allocates in the same order each run (see deterministic_argv)."""
    return {**os.environ, "PYTHONHASHSEED": "0"}


@functools.cache
def _no_randomization_prefix() -> tuple[str, ...]:
    prefix = ("setarch", platform.machine(), "--addr-no-randomize")
    if shutil.which("setarch") is None:
        return ()
    try:
        works = subprocess.run([*prefix, "true"], capture_output=True, timeout=10).returncode == 0
    except (OSError, subprocess.TimeoutExpired):
        works = False
    return prefix if works else ()


def deterministic_argv(argv: list[str]) -> list[str]:
    """A command line that runs with address-space randomisation off where the system allows it (util-linux's
    setarch). proxsuite's QP results differ in their last bits with the alignment of its stack and heap buffers,
    which randomisation changes from run to run; a long flight amplifies that, so the same scenario could give two
    different time series. Where setarch is missing or refused, the command runs as it is."""
    return [*_no_randomization_prefix(), *argv]


@dataclass(frozen=True)
class LinkPorts:
    """The autopilot's two ground-station links: the UDP ports it binds and those it sends to until a client
    speaks (GCS link, API/offboard link)."""

    gcs_bind: int
    gcs_remote: int
    api_bind: int
    api_remote: int

    def argv(self) -> list[str]:
        """The vtol-autopilot options that set them."""
        return [*_option("--gcs-port", self.gcs_bind), *_option("--gcs-remote-port", self.gcs_remote),
                *_option("--api-port", self.api_bind), *_option("--api-remote-port", self.api_remote)]  # fmt: skip


def free_link_ports() -> LinkPorts:
    """Ground-station links on free ports (nobody listens on the remote ones), so an autopilot can run beside a
    `vtol up` or another one."""
    return LinkPorts(*lease_ports([socket.SOCK_DGRAM] * 4))


@dataclass(frozen=True)
class VehiclePorts:
    """Every port of one vehicle: the plant link, the ground-station links, both processes' zenoh endpoints."""

    plant: int
    links: LinkPorts
    zenoh_plant: str
    zenoh_autopilot: str

    @classmethod
    def of_instance(cls, instance: int) -> VehiclePorts:
        """An instance's ports (`--instance I`)."""
        ports = Ports(instance)
        links = LinkPorts(ports.gcs_bind, ports.gcs_remote, ports.api_bind, ports.api_remote)
        return cls(ports.plant, links, ports.zenoh_plant, ports.zenoh_autopilot)

    @classmethod
    def free(cls) -> VehiclePorts:
        """Free ports, so a vehicle can run beside `vtol up` or another vehicle."""
        plant, *links, zenoh_plant, zenoh_autopilot = lease_ports([socket.SOCK_DGRAM] * 5 + [socket.SOCK_STREAM] * 2)
        return cls(plant, LinkPorts(*links), zenoh_endpoint(zenoh_plant), zenoh_endpoint(zenoh_autopilot))


# ---- the command lines -----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Zenoh:
    """A process's zenoh telemetry: off, or on (at its instance's default endpoint unless `listen` names some)."""

    enabled: bool = True
    listen: tuple[str, ...] = ()

    @classmethod
    def off(cls) -> Zenoh:
        return cls(enabled=False)

    @classmethod
    def listening(cls, *endpoints: str) -> Zenoh:
        return cls(listen=endpoints)

    def argv(self) -> list[str]:
        if not self.enabled:
            return ["--no-zenoh"]
        return [arg for endpoint in self.listen for arg in ("--zenoh-listen", endpoint)]


@dataclass(frozen=True)
class SimCommand:
    """A `vtol-sim` run: the plant, in lockstep with its autopilot or paced to the wall clock."""

    instance: int | None = None  # shifts every default port (vtol-sim's default: 0)
    port: int | None = None  # the plant link's UDP port (default 4560 + instance)
    autopilot_port: int | None = None  # belong only to the autopilot bound to this port (default: the first one)
    spawn_alt: float = 0.0  # m; above 0: spawned hovering there
    realtime_speed: float | None = None  # None: lockstep; F: paced to F simulated seconds per wall second
    duration_s: float | None = None  # simulated seconds, then stop
    lockstep_timeout_s: float | None = None  # how long a step waits for its command (vtol-sim's default: 0.5 s)
    summary: bool = False  # a JSON line of counters on stdout at the end
    zenoh: Zenoh = field(default_factory=Zenoh)
    airframe: Path | None = None
    wind_ned: tuple[float, float, float] | None = None  # m/s (vtol-sim's default: no wind)
    wind_turbulence: float = 0.0  # m/s, the Dryden gusts' vertical standard deviation (vtol-sim's default: none)
    wind_seed: int = 0  # the turbulence's seed
    sysid: int | None = None  # the vehicle's system id (vtol-sim's default: instance + 1)
    home: Home | None = None  # geodetic origin (default: PX4's, or PX4_HOME_LAT/LON/ALT)
    plant_signing_key: Path | None = None  # a key file: the plant link signed (docs/plant-link.md#signing)
    extra: tuple[str, ...] = ()  # further vtol-sim options, as they are

    def argv(self) -> list[str]:
        pacing = [] if self.realtime_speed is None else ["--realtime", "--speed", str(self.realtime_speed)]
        return python_module(SIM_MODULE, [
            *_option("--instance", self.instance), *_option("--port", self.port),
            *_option("--autopilot-port", self.autopilot_port),
            *_option("--spawn-alt", self.spawn_alt or None), *pacing, *_option("--duration", self.duration_s),
            *_option("--lockstep-timeout", self.lockstep_timeout_s), *_flag("--summary", self.summary),
            *self.zenoh.argv(), *_option("--airframe", self.airframe), *_wind(self.wind_ned),
            *_option("--wind-turbulence", self.wind_turbulence or None), *_option("--wind-seed", self.wind_seed or None),
            *_option("--sysid", self.sysid), *_home(self.home), *_option("--plant-signing-key", self.plant_signing_key),
            *self.extra,
        ])  # fmt: skip


@dataclass(frozen=True)
class AutopilotCommand:
    """A `vtol-autopilot` run: the flight controller, talking to its plant and to ground stations."""

    instance: int | None = None  # shifts every default port (vtol-autopilot's default: 0)
    sim_port: int | None = None  # the plant's UDP port (default 4560 + instance)
    sim_bind_port: int | None = None  # the plant link's own UDP port (default: any; see SimCommand.autopilot_port)
    links: LinkPorts | None = None  # the ground-station links (default: the instance's)
    gcs_bind: str | None = None  # the IPv4 address the GCS link listens on (vtol-autopilot's default: 127.0.0.1)
    spawn_alt: float = 0.0  # m; above 0: starts hovering there, armed (as the plant is spawned)
    controller: Controller | None = None  # default: the VT_CTRL parameter
    mpc_horizon: str | None = None  # the MPC's horizon, "paper" or "long" (default: the VT_MPC_HRZN parameter)
    params: Path | None = None  # the parameter file (default: the user's state folder)
    airframe: Path | None = None  # airframe TOML for the controllers' model
    profile: str | None = None  # an internal set-point profile (scenarios/profiles.py), flown from the start
    offboard_lockstep: bool = False  # hold the lockstep in Offboard until stamped set-points cover the time
    duration_s: float | None = None  # simulated seconds, then stop
    log: Path | None = None  # the 100 Hz flight log (transport/flight_log.py)
    root: Path | None = None  # the vehicle's file root (ULogs in root/log, MAVLink FTP; default microsd-I)
    log_dir: Path | None = None  # where the ULogs go (default root/log)
    summary: bool = False  # a JSON line of counters on stdout at the end
    quiet: bool = False  # no flight events (STATUSTEXT) on stderr
    zenoh: Zenoh = field(default_factory=Zenoh)
    sysid: int | None = None  # default: MAV_SYS_ID when changed, else instance + 1
    home: Home | None = None  # geodetic origin, the plant's (default: PX4's, or PX4_HOME_LAT/LON/ALT)
    plant_signing_key: Path | None = None  # the plant's key file (SimCommand.plant_signing_key)
    extra: tuple[str, ...] = ()  # further vtol-autopilot options, as they are

    def argv(self) -> list[str]:
        return python_module(AUTOPILOT_MODULE, [
            *_option("--instance", self.instance), *_option("--sim-port", self.sim_port),
            *_option("--sim-bind-port", self.sim_bind_port),
            *(self.links.argv() if self.links is not None else []), *_option("--gcs-bind", self.gcs_bind),
            *_option("--spawn-alt", self.spawn_alt or None),
            *_option("--controller", self.controller), *_option("--mpc-horizon", self.mpc_horizon),
            *_option("--params", self.params),
            *_option("--airframe", self.airframe), *_option("--profile", self.profile),
            *_flag("--offboard-lockstep", self.offboard_lockstep), *_option("--duration", self.duration_s),
            *_option("--log", self.log), *_option("--root", self.root), *_option("--log-dir", self.log_dir),
            *_flag("--summary", self.summary), *_flag("--quiet", self.quiet),
            *self.zenoh.argv(), *_option("--sysid", self.sysid), *_home(self.home),
            *_option("--plant-signing-key", self.plant_signing_key), *self.extra,
        ])  # fmt: skip
