"""tiltrotor_sitl: the emulated tilt-rotor VTOL as a test fixture (docs/testing.md).

    from tiltrotor_sitl import Vehicle

    with Vehicle(controller="mpc", speed=2.0) as vehicle:      # plant + autopilot on free ports, ready to arm
        master = mavutil.mavlink_connection(vehicle.pymavlink)  # "udpin:127.0.0.1:P", where the vehicle sends
        ...                                                     # or MAVSDK: System().connect(vehicle.mavsdk)
        vehicle.truth.wait_until(lambda s: s.altitude > 9.5, timeout_sim_s=20)  # the plant's truth (zenoh)

    with Fleet(3) as fleet:                                     # system ids 1, 2, 3, 5 m apart, one GCS port
        master = mavutil.mavlink_connection(fleet.pymavlink)

Everything a `Vehicle` or `Fleet` starts is stopped by PID when the block ends, on an exception (a failed test, a
Ctrl-C), and, on Linux, when the process that started it dies, even by SIGKILL (PR_SET_PDEATHSIG; start vehicles
from the main thread or another thread that lives as long as they do). Bad arguments raise ValueError; anything
else that prevents a start (a port in use, a process that dies, no readiness in time) raises VehicleError with
the cause, and nothing is left running.

The pytest plugin (fixtures `vehicle`, `fleet_factory`, `vehicle_factory`; options --vtol-controller,
--vtol-speed) is in tiltrotor_sitl/pytest_plugin.py.
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path
from types import TracebackType
from typing import Unpack

from tiltrotor_sitl._children import Child
from tiltrotor_sitl._commands import Controller, VehiclePorts
from tiltrotor_sitl._launch import Options, Started, VehicleError, VehicleOptions, launch, stop
from tiltrotor_sitl.truth import PlantTruth, TruthFeed, TruthTimeout
from transport.geodesy import Home
from transport.ports import LOOPBACK
from transport.wind import Wind

__all__ = ["Controller", "Fleet", "Home", "PlantTruth", "TruthFeed", "TruthTimeout", "Vehicle", "VehicleError",
           "VehicleHandle", "VehicleOptions", "VehiclePorts", "Wind"]  # fmt: skip


class VehicleHandle:
    """One running vehicle of a Vehicle or Fleet: its identity, connection strings, processes and truth."""

    def __init__(self, started: Started) -> None:
        self._started = started

    @property
    def sysid(self) -> int:
        """MAVLink system id (MAV_SYS_ID)."""
        return self._started.sysid

    @property
    def home(self) -> Home:
        """Where the vehicle stands: its local NED frame's origin."""
        return self._started.home

    @property
    def gcs_port(self) -> int:
        """The UDP port on 127.0.0.1 the vehicle's GCS link sends to (a ground station listens there)."""
        return self._started.ports.links.gcs_remote

    @property
    def api_port(self) -> int:
        """The UDP port on 127.0.0.1 the vehicle's API (offboard) link sends to (MAVSDK listens there)."""
        return self._started.ports.links.api_remote

    @property
    def ports(self) -> VehiclePorts:
        """Every port of the vehicle: the plant link (`plant`), its own link ports (`links.gcs_bind`,
        `links.api_bind`, where ground stations may also send first), where the links send (`links.gcs_remote`,
        `links.api_remote`) and both processes' zenoh endpoints."""
        return self._started.ports

    @property
    def params_path(self) -> Path:
        """The autopilot's parameter file (its missions are kept beside it, in missions-<instance>.json)."""
        return self._started.params_path

    @property
    def pymavlink(self) -> str:
        """For mavutil.mavlink_connection: listen where the GCS link sends."""
        return f"udpin:{LOOPBACK}:{self.gcs_port}"

    @property
    def mavsdk(self) -> str:
        """For MAVSDK's System().connect(system_address=...): listen where the API link sends."""
        return f"udpin://{LOOPBACK}:{self.api_port}"

    @property
    def mavproxy(self) -> str:
        """For mavproxy.py --master=... (QGroundControl: a UDP comm link listening on gcs_port)."""
        return f"udpin:{LOOPBACK}:{self.gcs_port}"

    @property
    def pids(self) -> list[int]:
        """The PIDs of the processes it started (plant, autopilot; one of them when started alone)."""
        return [child.pid for child in self._started.children]

    @property
    def truth(self) -> TruthFeed:
        """The plant's truth on zenoh (raises VehicleError when started with truth=False or with plant_port)."""
        truth = self._started.truth
        if truth is None:
            raise VehicleError(f"vehicle {self.sysid}: no truth: started with truth=False (no zenoh) or with "
                               f"plant_port (no plant of its own), or already stopped")  # fmt: skip
        return truth

    def running(self) -> bool:
        """Every process it started is running."""
        return all(child.running() for child in self._started.children)

    def stderr(self, process: str = "vtol-autopilot") -> str:
        """What `process` (vtol-autopilot or vtol-sim) has said on stderr so far (across restarts)."""
        return self._child(process).stderr_text()

    def process(self, process: str = "vtol-autopilot") -> subprocess.Popen:
        """The running `process` (vtol-autopilot or vtol-sim), to signal it or wait for it (a test of a crash, a
        kill -9, an exit code). Whatever state it is left in, the vehicle still stops it at the end."""
        return self._child(process).process

    def summary(self, process: str = "vtol-autopilot") -> dict:
        """With summary=True: the counters `process` printed as JSON when it last stopped (after the test
        signalled it, or after stop() when the vehicle was given a `folder`: a temporary one is removed), {} while
        it runs."""
        return self._child(process).summary()

    def restart(self, process: str = "vtol-autopilot") -> None:
        """Stop `process` if it still runs (SIGTERM, then SIGKILL after 5 s) and start it again with the same
        command line, ports and parameter file, as after a power cycle. Returns at once: wait for its HEARTBEAT."""
        self._child(process).restart()

    def wait_finished(self, timeout_s: float = 600.0) -> None:
        """With duration_s: wait until the processes have stopped by themselves (their summary() is then there to
        read). VehicleError if one exits with an error (its last stderr lines) or one still runs after `timeout_s`
        wall seconds (it is stopped with the vehicle)."""
        deadline = time.monotonic() + timeout_s
        while True:
            for child in self._started.children:
                if not child.running() and child.returncode != 0:
                    raise VehicleError(f"vehicle {self.sysid}: {child.describe_exit('before the end')}")
            running = [child for child in self._started.children if child.running()]
            if not running:
                return
            if time.monotonic() > deadline:
                names = ", ".join(f"{child.name} (pid {child.pid})" for child in running)
                raise VehicleError(f"vehicle {self.sysid}: {names} still running after {timeout_s:g} s")
            time.sleep(0.02)

    def _child(self, process: str) -> Child:
        for child in self._started.children:
            if child.name == process:
                return child
        started = " and ".join(child.name for child in self._started.children) or "nothing"
        raise ValueError(f"no process {process!r}: this vehicle started {started}")


class Fleet:
    """`count` vehicles, as PX4's multi-vehicle SITL runs them: system ids sysid .. sysid+count-1 (default 1, or
    instance + 1), every GCS link sending to one port (14550 with `instance`, else a free one, or `gcs_port`), each
    vehicle FLEET_SPACING_M (5 m) east of the previous one. Arguments as for Vehicle. A context manager; or call
    start() and stop(). params_file is for a single Vehicle only."""

    def __init__(self, count: int, **options: Unpack[VehicleOptions]) -> None:
        self.count = count
        self.options = Options.of(options)
        self.options.check(count)
        self._started: list[Started] = []
        self._root: Path | None = None
        self.vehicles: list[VehicleHandle] = []
        self.ready_s = float("nan")  # seconds from start() to every vehicle ready to arm

    def start(self) -> Fleet:
        if self._started:
            raise VehicleError("already started")
        self._started, self._root, self.ready_s = launch(self.options, self.count)
        self.vehicles = [VehicleHandle(started) for started in self._started]
        return self

    def stop(self) -> None:
        """Stop every process started (SIGTERM, then SIGKILL after 5 s), by PID. Safe to call twice."""
        stop(self._started, self._root if self.options.folder is None else None)
        self._started = []

    def __enter__(self) -> Fleet:
        return self.start()

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:  # fmt: skip
        self.stop()

    @property
    def gcs_port(self) -> int:
        """The one UDP port every vehicle's GCS link sends to."""
        return self.vehicles[0].gcs_port

    @property
    def pymavlink(self) -> str:
        """One ground station for the whole fleet (tell the vehicles apart by system id)."""
        return self.vehicles[0].pymavlink

    @property
    def pids(self) -> list[int]:
        return [pid for vehicle in self.vehicles for pid in vehicle.pids]


class Vehicle(VehicleHandle):
    """One vehicle: the plant (`vtol-sim`) and the autopilot (`vtol-autopilot`), started on entering the block and
    ready to arm (HEARTBEAT past BOOT, HOME_POSITION, SYS_STATUS pre-arm check) when the block begins.

    Its keyword arguments (VehicleOptions; a Fleet's are the same): controller: "mpc" (the unified MPC) or "pid"
    (the PX4-style baseline). airframe: an airframe TOML for both processes (default: the paper's vehicle).
    spawn_alt: metres; above 0 the vehicle starts hovering there, armed, in Hold. home: its geodetic origin
    (Home(lat, lon, alt)). speed: simulated seconds per wall second (the lockstep paced to the wall clock), or None:
    lockstep as fast as the processes go. params: PX4-style parameters (name -> value) written to the vehicle's
    parameter file before the start (checked: an unknown name or a value out of range is a ValueError). instance:
    None (default) for free ports, or I for instance I's ports (docs/plant-link.md: plant 4560+I, API 14540+I, GCS
    to 14550, system id I+1). sysid: the system id (default: params' MAV_SYS_ID, else I+1, else 1). gcs_port: where
    the GCS link sends (default: a free port, 14550 with an instance). truth: subscribe to the plant's truth on
    zenoh. ready_timeout_s: wall seconds to wait for readiness. folder: where the parameter file and the processes'
    stdout and stderr go (default: a temporary folder, removed at the end). summary: both processes print their
    counters when they stop (see summary()). autopilot_args: further vtol-autopilot options, as they are
    (`vtol-autopilot --help`, e.g. ["--quiet"]). wait_ready: False returns as soon as both processes are started (to
    test start-up itself, e.g. a refused file). params_file: the parameter file the autopilot keeps (default:
    params.json in the vehicle's folder); an existing one is used as it is, with `params` set into it, and it stays
    after the stop, with the missions beside it: a later Vehicle given the same file starts where this one stopped.
    duration_s: both processes stop by themselves after that many simulated seconds (wait for it with
    wait_finished()). plant_args: further vtol-sim options, as they are (`vtol-sim --help`, e.g. ["--wind",
    "0,3,0"]). wind: the plant's wind, Wind(speed_mps, from_deg, turbulence_mps, seed) (mean and Dryden
    turbulence; docs/plant-link.md "Wind"; a ground station or test changes it in flight through the SIM_WIND_*
    parameters).

    Which processes: both (default); autopilot=False starts the plant alone, for a flight controller of your own or
    a test that plays one on `ports.plant` (ready when the plant says it listens; `truth` works); plant_port=P starts
    the autopilot alone, flying the plant already running on UDP port P (yours, or a plant started with
    autopilot=False), ready to arm once that plant steps it (with a plant that a test steps by hand, pass
    wait_ready=False); `truth` then only turns the autopilot's zenoh telemetry on."""

    def __init__(self, **options: Unpack[VehicleOptions]) -> None:
        self._fleet = Fleet(1, **options)

    def start(self) -> Vehicle:
        self._fleet.start()
        super().__init__(self._fleet._started[0])
        return self

    def stop(self) -> None:
        """Stop both processes (by PID). Safe to call twice."""
        self._fleet.stop()

    @property
    def ready_s(self) -> float:
        """Seconds from start() to ready to arm."""
        return self._fleet.ready_s

    def __enter__(self) -> Vehicle:
        return self.start()

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:  # fmt: skip
        self.stop()
