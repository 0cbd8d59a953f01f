"""tiltrotor_sitl: the emulated tilt-rotor VTOL as a test fixture (docs/testing.md).

    from tiltrotor_sitl import Vehicle

    with Vehicle(controller="mpc", speed=2.0) as vehicle:      # plant + autopilot on free ports, ready to arm
        gcs = vehicle.ground_station                            # pymavlink, connected, saying HEARTBEAT
        gcs.arm()
        gcs.takeoff(8.0)
        vehicle.truth.wait_until(lambda s: s.altitude > 7.5, timeout_sim_s=30)  # the plant's truth (zenoh)
        print(vehicle.truth.max(lambda s: s.altitude))          # ... recorded: queried after the fact

    with Fleet(3) as fleet:                                     # system ids 1, 2, 3, 5 m apart, one GCS port
        for vehicle in fleet:
            vehicle.ground_station.arm()

Your own pymavlink connection instead: mavutil.mavlink_connection(vehicle.pymavlink) ("udpin:127.0.0.1:P", where
the vehicle sends); MAVSDK 4: Mavsdk(...).add_any_connection(vehicle.mavsdk).

Everything a `Vehicle` or `Fleet` starts is stopped by PID when the block ends, on an exception (a failed test, a
Ctrl-C), and, on Linux, when the process that started it dies, even by SIGKILL (PR_SET_PDEATHSIG; start vehicles
from the main thread or another thread that lives as long as they do). Bad arguments raise ValueError; anything
else that prevents a start (a port in use, a process that dies, no readiness in time) raises VehicleError with
the cause, and nothing is left running.

The pytest plugin (fixtures `vehicle`, `fleet_factory`, `vehicle_factory`; options --vtol-controller,
--vtol-speed, --vtol-keep-logs) is in tiltrotor_sitl/pytest_plugin.py.
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType
from typing import Unpack

from autopilot.reboot import started_sysid
from autopilot.storage.vehicle_files import VehicleFiles
from autopilot.topics.mission_items import MissionItem
from tiltrotor_sitl._children import Child
from tiltrotor_sitl._commands import Controller, VehiclePorts
from tiltrotor_sitl._free_ports import bind_error
from tiltrotor_sitl._launch import (
    Options,
    ProcessOptions,
    Started,
    VehicleError,
    VehicleOptions,
    launch,
    stop,
)
from tiltrotor_sitl.fault_proxy import DOWNSTREAM, UPSTREAM, FaultProxy, Faults
from tiltrotor_sitl.flight_modes import FlightMode
from tiltrotor_sitl.ground_station import (
    CommandError,
    CommandRefused,
    CommandTimeout,
    GroundLink,
    GroundStation,
    StatusReport,
)
from tiltrotor_sitl.mission_items import landing, waypoint
from tiltrotor_sitl.truth import PlantTruth, Trajectory, TruthFeed, TruthHistory, TruthTimeout
from transport.geodesy import Home
from transport.ports import LOOPBACK
from transport.wind import Wind

__version__ = importlib.metadata.version("tiltrotor-sitl")
__all__ = ["CommandError", "CommandRefused", "CommandTimeout", "Controller", "Faults", "Fleet", "FlightMode",
           "GroundStation", "Home", "MissionItem", "PlantTruth", "ProcessOptions", "StatusReport", "Trajectory",
           "TruthFeed", "TruthHistory", "TruthTimeout", "Vehicle", "VehicleError", "VehicleHandle", "VehicleOptions",
           "VehiclePorts", "Wind", "__version__", "landing", "waypoint"]  # fmt: skip
TLOG_FILE = "gcs.tlog"  # the ground station's MAVLink log, in the folder of the Vehicle or Fleet


class VehicleHandle:
    """One vehicle of a Vehicle or Fleet: its identity, connection strings, processes, folder, truth and ground
    station. A VehicleError says so when it is used before its Vehicle or Fleet is started."""

    def __init__(self, fleet: Fleet, index: int) -> None:
        self._fleet = fleet
        self._index = index
        self._station: GroundStation | None = None

    @property
    def _vehicle(self) -> Started:
        return self._fleet._record(self._index)

    @property
    def sysid(self) -> int:
        """MAVLink system id (MAV_SYS_ID): the one the autopilot last started with, as it says on stderr (a reboot
        after a change of MAV_SYS_ID changes it), else the one it was started with."""
        vehicle = self._vehicle
        for child in vehicle.children:
            if child.name == "vtol-autopilot":
                try:
                    said = started_sysid(child.stderr_text())
                except (OSError, ValueError):  # its stderr file is gone (a removed folder) or not kept
                    said = None
                return vehicle.sysid if said is None else said
        return vehicle.sysid

    @property
    def home(self) -> Home:
        """Where the vehicle stands: its local NED frame's origin."""
        return self._vehicle.home

    @property
    def gcs_port(self) -> int:
        """The UDP port on 127.0.0.1 the vehicle's GCS link sends to (a ground station listens there)."""
        return self._vehicle.ports.links.gcs_remote

    @property
    def api_port(self) -> int:
        """The UDP port on 127.0.0.1 the vehicle's API (offboard) link sends to (MAVSDK listens there)."""
        return self._vehicle.ports.links.api_remote

    @property
    def ports(self) -> VehiclePorts:
        """Every port of the vehicle: the plant link (`plant`), its own link ports (`links.gcs_bind`,
        `links.api_bind`, where ground stations may also send first), where the links send (`links.gcs_remote`,
        `links.api_remote`) and both processes' zenoh endpoints."""
        return self._vehicle.ports

    @property
    def params_path(self) -> Path:
        """The autopilot's parameter file (its missions are kept beside it, in missions-<instance>.json)."""
        return self._vehicle.params_path

    @property
    def tlog_path(self) -> Path:
        """The .tlog of the ground station (ground_station), in the folder of its Vehicle or Fleet."""
        return self._fleet.folder / TLOG_FILE

    @property
    def folder(self) -> Path:
        """The vehicle's folder: its processes' output, and its file root as MAVLink FTP serves it (PX4's
        /fs/microsd): its parameter file (unless params_file), the ULogs in log/YYYY-MM-DD/HH_MM_SS.ulg (docs/logs.md).
        A temporary one is removed at the stop; give the Vehicle a `folder` to keep the logs (the pytest plugin
        keeps it under the test's tmp_path)."""
        return self._vehicle.folder

    @property
    def log_dir(self) -> Path:
        """Where the autopilot writes its ULogs (folder/log)."""
        return VehicleFiles.at(self._vehicle.folder).log_dir

    def logs(self) -> list[Path]:
        """The ULogs written so far, oldest first."""
        return [entry.path for entry in VehicleFiles.at(self._vehicle.folder).logs()]

    @property
    def pymavlink(self) -> str:
        """For mavutil.mavlink_connection: listen where the GCS link sends."""
        return f"udpin:{LOOPBACK}:{self.gcs_port}"

    @property
    def mavsdk(self) -> str:
        """For MAVSDK 4's Mavsdk.add_any_connection(...): listen where the API link sends."""
        return f"udpin://{LOOPBACK}:{self.api_port}"

    @property
    def mavproxy(self) -> str:
        """For mavproxy.py --master=... (QGroundControl: a UDP comm link listening on gcs_port)."""
        return f"udpin:{LOOPBACK}:{self.gcs_port}"

    @property
    def pids(self) -> list[int]:
        """The PIDs of the processes it started (plant, autopilot; one of them when started alone)."""
        return [child.pid for child in self._vehicle.children]

    @property
    def truth(self) -> TruthFeed:
        """The plant's truth on zenoh, every sample since the vehicle was ready (raises VehicleError when started
        with truth=False or with plant_port)."""
        truth = self._vehicle.truth
        if truth is None:
            raise VehicleError(f"vehicle {self.sysid}: no truth: started with truth=False (no zenoh) or with "
                               f"plant_port (no plant of its own), or already stopped")  # fmt: skip
        return truth

    @property
    def ground_station(self) -> GroundStation:
        """A pymavlink ground station on the vehicle's GCS link (tiltrotor_sitl/ground_station.py), connected (its
        HEARTBEAT heard) and saying the ground station's HEARTBEAT each second; made on first use, closed with the
        vehicle. It listens on gcs_port: use it or a pymavlink connection of your own on `pymavlink`, not both (a
        fleet's vehicles share one link, each its own GroundStation)."""
        if self._station is None or self._station.target_system != self.sysid:  # a reboot changed MAV_SYS_ID
            self._station = self._fleet._ground_link().station(self.sysid)
            self._station.wait_connected()
        return self._station

    def running(self) -> bool:
        """Every process it started is running."""
        return all(child.running() for child in self._vehicle.children)

    def stderr(self, process: str = "vtol-autopilot") -> str:
        """What `process` (vtol-autopilot or vtol-sim) has said on stderr so far (across restarts)."""
        return self._child(process).stderr_text()

    def stderr_tail(self, process: str = "vtol-autopilot", lines: int = 20) -> str:
        """The last `lines` lines `process` has said on stderr ("" when it said nothing or its file is gone)."""
        return self._child(process).stderr_tail(lines)

    @property
    def process_names(self) -> list[str]:
        """The processes it started: vtol-sim, vtol-autopilot (one of them when started alone)."""
        return [child.name for child in self._vehicle.children]

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
            for child in self._vehicle.children:
                if not child.running() and child.returncode != 0:
                    raise VehicleError(f"vehicle {self.sysid}: {child.describe_exit('before the end')}")
            running = [child for child in self._vehicle.children if child.running()]
            if not running:
                return
            if time.monotonic() > deadline:
                names = ", ".join(f"{child.name} (pid {child.pid})" for child in running)
                raise VehicleError(f"vehicle {self.sysid}: {names} still running after {timeout_s:g} s")
            time.sleep(0.02)

    def status(self, timeout_s: float = 3.0) -> StatusReport:
        """What the vehicle last said of itself (mode, armed, MAV_STATE, landed state) and the last failsafe it
        announced. From its ground station when one is in use; otherwise asked by a ground station speaking first to
        the vehicle's own GCS port for up to `timeout_s` wall seconds, after which the vehicle also sends there and
        no longer to a listener that never spoke: call it once the test is done with the vehicle (the pytest plugin
        does, on a failure)."""
        if self._station is not None:
            report = self._station.status()
        elif "vtol-autopilot" not in self.process_names or not self._child("vtol-autopilot").running():
            report = StatusReport(None, None, None, None, None)
        else:
            report = _asked_status(self._gcs_address(), self.ports.links.gcs_bind, self.sysid, timeout_s)
        if report.failsafe is None and "vtol-autopilot" in self.process_names:
            said = [line for line in self.stderr().splitlines() if "failsafe" in line.lower()]
            report = dataclasses.replace(report, failsafe=said[-1] if said else None)
        return report

    def _gcs_address(self) -> str:
        """Where the vehicle's GCS link listens: its gcs_bind, loopback when that is every interface or unset."""
        bind = self._fleet.options.gcs_bind
        return LOOPBACK if bind in (None, "0.0.0.0") else bind

    def set_link_faults(self, to_vehicle: Faults, to_ground: Faults | None = None) -> None:
        """With link_faults: change the faults of its ground-station links (GCS and API) while it flies, each
        direction on its own (to_ground: the same as to_vehicle when None); e.g. Faults(loss=1.0) to the vehicle
        alone: the ground stations' messages stop arriving, the vehicle's still do."""
        for proxy in self._proxies():
            proxy.set_faults(to_ground if to_ground is not None else to_vehicle, to_vehicle)

    def link_fault_counts(self) -> dict[str, dict[str, dict[str, int]]]:
        """With link_faults: what the faults did so far, per link ("gcs", "api") and direction ("to_vehicle",
        "to_ground"): datagrams received, sent, lost, duplicated, reordered, delayed."""
        counts = {}
        for name, proxy in zip(("gcs", "api"), self._proxies()):
            summary = proxy.summary()
            counts[name] = {"to_ground": summary[UPSTREAM], "to_vehicle": summary[DOWNSTREAM]}
        return counts

    def _proxies(self) -> list[FaultProxy]:
        proxies = self._vehicle.proxies
        if not proxies:
            raise VehicleError(f"vehicle {self.sysid}: started without link_faults: its links have no fault proxy")
        return proxies

    def _child(self, process: str) -> Child:
        for child in self._vehicle.children:
            if child.name == process:
                return child
        started = " and ".join(child.name for child in self._vehicle.children) or "nothing"
        raise ValueError(f"no process {process!r}: this vehicle started {started}")


def _asked_status(address: str, port: int, sysid: int, timeout_s: float) -> StatusReport:
    """The status of vehicle `sysid`, asked by a ground station speaking first to its GCS port `address`:`port`."""
    link = GroundLink.speaking_to(port, address=address)
    try:
        station = link.station(sysid)
        if station.next_message("HEARTBEAT", timeout_s=timeout_s) is not None:  # else: "no HEARTBEAT heard"
            station.next_message("EXTENDED_SYS_STATE", timeout_s=timeout_s)
        return station.status()
    finally:
        link.close()


class Fleet:
    """`count` vehicles, as PX4's multi-vehicle SITL runs them: system ids sysid .. sysid+count-1 (default 1, or
    instance + 1), every GCS link sending to one port (14550 with `instance`, else a free one, or `gcs_port`), each
    vehicle FLEET_SPACING_M (5 m) east of the previous one. Arguments as for Vehicle. A context manager, or call
    start() and stop(); iterable and indexable (fleet[0], for vehicle in fleet), once started. params_file is for
    a single Vehicle only."""

    def __init__(self, count: int, **options: Unpack[VehicleOptions]) -> None:
        self.count = count
        self.options = Options.of(options)
        self.options.check(count)
        self._started: list[Started] = []
        self._running = False
        self._root: Path | None = None
        self._link: GroundLink | None = None
        self.vehicles: list[VehicleHandle] = []
        self.ready_s = float("nan")  # seconds from start() to every vehicle ready to arm

    def start(self) -> Fleet:
        if self._running:
            raise VehicleError("already started")
        self._started, self._root, self.ready_s = launch(self.options, self.count)
        self._running = True
        self.vehicles = [VehicleHandle(self, index) for index in range(self.count)]
        return self

    def stop(self) -> None:
        """Stop every process started (SIGTERM, then SIGKILL after 5 s), by PID, and the ground station. Safe to
        call twice."""
        if self._link is not None:
            self._link.close()
            self._link = None
        stop(self._started, self._root if self.options.folder is None else None)
        self._running = False

    def __enter__(self) -> Fleet:
        return self.start()

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 traceback: TracebackType | None) -> None:  # fmt: skip
        self.stop()

    def __len__(self) -> int:
        return self.count

    def __iter__(self) -> Iterator[VehicleHandle]:
        self._record(0)
        return iter(self.vehicles)

    def __getitem__(self, index: int) -> VehicleHandle:
        self._record(0)
        return self.vehicles[index]

    @property
    def folder(self) -> Path:
        """Where the vehicles' folders (vehicle-<sysid>/) and the ground station's .tlog are."""
        return self._record(0).folder.parent

    @property
    def gcs_port(self) -> int:
        """The one UDP port every vehicle's GCS link sends to."""
        return self[0].gcs_port

    @property
    def pymavlink(self) -> str:
        """One ground station for the whole fleet (tell the vehicles apart by system id)."""
        return self[0].pymavlink

    @property
    def pids(self) -> list[int]:
        return [pid for vehicle in self for pid in vehicle.pids]

    def _record(self, index: int) -> Started:
        """The started vehicle `index` (kept after stop(), for its summary and files); VehicleError before start()."""
        if not self._started:
            raise VehicleError("not started: use `with Vehicle(...) as vehicle:` (or Fleet), or call start() first")
        return self._started[index]

    def _ground_link(self) -> GroundLink:
        """The fleet's one ground-station link on its GCS port, made on first use; VehicleError when the port is
        held (a pymavlink connection of the user's own there) or the fleet is not running."""
        self._record(0)
        if not self._running:
            raise VehicleError("stopped: a ground station needs a running Vehicle or Fleet")
        if self._link is None:
            port = self.gcs_port
            taken = bind_error(socket.SOCK_DGRAM, port)
            if taken is not None:
                raise VehicleError(f"cannot listen on the GCS port {LOOPBACK}:{port}: {taken.strerror} (a pymavlink "
                                   f"connection of your own on vehicle.pymavlink? use it or the ground_station, not "
                                   f"both)")  # fmt: skip
            self._link = GroundLink.listening(port, self.folder / TLOG_FILE)
        return self._link


class Vehicle(VehicleHandle):
    """One vehicle: the plant (`vtol-sim`) and the autopilot (`vtol-autopilot`), started on entering the block and
    ready to arm (HEARTBEAT past BOOT, HOME_POSITION, SYS_STATUS pre-arm check) when the block begins.

    The everyday keyword arguments (a Fleet's are the same): controller: "mpc" (the unified MPC, default) or "pid"
    (the PX4-style baseline). speed: simulated seconds per wall second (the lockstep paced to the wall clock); 0 or
    None: lockstep as fast as the processes go. spawn_alt: metres; above 0 the vehicle starts hovering there, armed,
    in Hold. params: PX4-style parameters (name -> value) written to the vehicle's parameter file before the start
    (checked: an unknown name or a value out of range is a ValueError). home: its geodetic origin (Home(lat, lon,
    alt)). airframe: an airframe TOML for both processes (default: the paper's vehicle). link_faults: Faults(loss=,
    duplicate=, reorder=, delay_s=, jitter_s=) on its ground-station links (GCS and API), both ways, through a seeded
    fault proxy (tiltrotor_sitl/fault_proxy.py; change them in flight with set_link_faults()). wind: the plant's
    wind, Wind(from_north=, from_east=, turbulence=, seed=) (m/s where the mean wind comes from, as PX4's SIH_WIND_N
    and SIH_WIND_E; Dryden turbulence; docs/plant-link.md "Wind"); a ground station or a test changes it in flight
    with those parameters and SIM_WIND_TURB, SIM_WIND_SEED.

    Where it lives: instance: None (default) for free ports, or I for instance I's ports (docs/plant-link.md: plant
    4560+I, API 14540+I, GCS to 14550, system id I+1). sysid: the system id (default: params' MAV_SYS_ID, else I+1,
    else 1). gcs_port: where the GCS link sends (default: a free port, 14550 with an instance). gcs_bind: the IPv4
    address the GCS link listens on (default 127.0.0.1; 0.0.0.0 for a ground station on another machine). truth: subscribe to
    the plant's truth on zenoh (default True). folder: where the vehicle's folder (vehicle-<sysid>/: parameter file,
    the processes' stdout and stderr, and its file root with the ULogs in log/) and the ground station's .tlog go
    (default: a temporary folder, removed at the end).

    The expert ones, grouped: processes=ProcessOptions(...): which processes start (the plant alone, the autopilot
    alone on a plant of yours), readiness, a duration, summaries, the parameter file kept, further command-line
    options (ProcessOptions says each)."""

    def __init__(self, **options: Unpack[VehicleOptions]) -> None:
        super().__init__(Fleet(1, **options), 0)

    def start(self) -> Vehicle:
        self._fleet.start()
        self._station = None  # a ground station of an earlier start went with its link
        return self

    def stop(self) -> None:
        """Stop both processes (by PID) and the ground station. Safe to call twice."""
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
