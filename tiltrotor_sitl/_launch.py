"""Starting vehicles: checked options, ports, parameter files, both processes of each vehicle, the wait until every
one is ready to arm, and the stop. The public classes are in tiltrotor_sitl/__init__.py."""

from __future__ import annotations

import math
import os
import shutil
import signal
import socket
import tempfile
import time
from argparse import ArgumentTypeError
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, TypedDict

from autopilot.storage.parameters import ParameterFileError, ParameterRejected, ParameterStore, vehicle_system_id
from tiltrotor_sitl import _children
from tiltrotor_sitl._children import Child
from tiltrotor_sitl._commands import (
    AutopilotCommand,
    Controller,
    LinkPorts,
    SimCommand,
    VehiclePorts,
    Zenoh,
    fleet_home,
    plant_wind,  # fmt: skip
)
from tiltrotor_sitl._free_ports import bind_error, free_udp_port, protocol
from tiltrotor_sitl._readiness import ReadinessWatch
from tiltrotor_sitl.fault_proxy import FaultProxy, Faults
from tiltrotor_sitl.truth import TruthFeed
from transport.cli import ipv4_address
from transport.geodesy import Home, home_from
from transport.ports import LOOPBACK, Ports, endpoint_port
from transport.wind import Wind

PLANT_LISTENING = "listening on udp"  # what vtol-sim says on stderr once its port is bound (sim_bridge/cli.py)


class VehicleError(RuntimeError):
    """A vehicle could not be started (the message names the cause); nothing it started is left running."""


@dataclass(frozen=True)
class ProcessOptions:
    """The expert arguments of Vehicle and Fleet (`processes=ProcessOptions(...)`): which processes start, how they
    are started and run, and what they are given besides the everyday arguments.

    autopilot: False starts the plant alone (for a flight controller of your own; ready when the plant says it
    listens). plant_port: P starts the autopilot alone, flying the plant already running on UDP port P. wait_ready:
    False returns as soon as the processes are started (to test start-up itself). ready_timeout_s: wall seconds to
    wait for readiness. duration_s: both processes stop by themselves after that many simulated seconds (wait for it
    with wait_finished()). summary: both processes print their counters when they stop (summary()). params_file:
    the parameter file the autopilot keeps (default: params.json in the vehicle's folder); an existing one is used as
    it is, with `params` set into it, and stays after the stop, with the missions beside it. autopilot_args,
    plant_args: further vtol-autopilot / vtol-sim options, as they are (`--help` lists them)."""

    autopilot: bool = True
    plant_port: int | None = None
    wait_ready: bool = True
    ready_timeout_s: float = 60.0
    duration_s: float | None = None
    summary: bool = False
    params_file: str | Path | None = None
    autopilot_args: Sequence[str] = ()
    plant_args: Sequence[str] = ()

    def check(self, count: int) -> None:
        """Raise ValueError naming the first bad argument."""
        for name, args in (("autopilot_args", self.autopilot_args), ("plant_args", self.plant_args)):
            if isinstance(args, str) or not all(isinstance(arg, str) for arg in args):
                raise ValueError(f"{name} must be a sequence of strings (command-line words), not {args!r}")
        if self.params_file is not None and count > 1:
            raise ValueError(f"params_file is for one vehicle, not a fleet of {count} (each keeps its own file)")
        if self.params_file is not None and Path(self.params_file).is_dir():
            raise ValueError(f"params_file is a folder, not a file: {self.params_file}")
        if self.duration_s is not None and not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"duration_s must be a positive number of simulated seconds (or None), not "
                             f"{self.duration_s!r}")  # fmt: skip
        if not self.ready_timeout_s > 0:
            raise ValueError(f"ready_timeout_s must be positive, not {self.ready_timeout_s}")
        self._check_which(count)

    def _check_which(self, count: int) -> None:
        """The arguments that choose which processes start (both, the plant alone, the autopilot alone)."""
        if self.plant_port is None:
            if not self.autopilot and self.autopilot_args:
                raise ValueError("autopilot_args with autopilot=False: no autopilot is started")
            return
        if not self.autopilot:
            raise ValueError("plant_port starts the autopilot alone and autopilot=False the plant alone: not both")
        if not 1 <= self.plant_port <= 65535:
            raise ValueError(f"plant_port must be a UDP port 1..65535, not {self.plant_port}")
        if count > 1:
            raise ValueError(f"plant_port is one plant for one autopilot, not a fleet of {count}")
        if self.plant_args:
            raise ValueError("plant_args with plant_port: no plant is started (the plant on plant_port is yours)")


class VehicleOptions(TypedDict, total=False):
    """The keyword arguments of Vehicle and Fleet, as a caller gives them (what each means: Vehicle's docstring):
    the everyday ones, where the vehicle lives, and the expert ones grouped in `processes`. Options holds them
    checked and with their defaults."""

    controller: Controller
    speed: float | None
    spawn_alt: float
    params: Mapping[str, float] | None
    home: Home | None
    airframe: str | Path | None
    link_faults: Faults | None
    wind: Wind | None
    instance: int | None
    sysid: int | None
    gcs_port: int | None
    gcs_bind: str | None
    truth: bool
    folder: str | Path | None
    processes: ProcessOptions


@dataclass(frozen=True)
class Options:
    """What every vehicle of one start shares (see Vehicle for the meaning of each): VehicleOptions with their
    defaults, paths as Path, speed 0 as None (lockstep as fast as possible)."""

    controller: Controller = "mpc"
    speed: float | None = 1.0
    spawn_alt: float = 0.0
    params: dict[str, float] = field(default_factory=dict)
    home: Home | None = None
    airframe: Path | None = None
    link_faults: Faults | None = None
    wind: Wind | None = None
    instance: int | None = None
    sysid: int | None = None
    gcs_port: int | None = None
    gcs_bind: str | None = None
    truth: bool = True
    folder: Path | None = None
    processes: ProcessOptions = ProcessOptions()

    @classmethod
    def of(cls, options: VehicleOptions) -> Options:
        """The options Vehicle's or Fleet's keyword arguments give; TypeError for a keyword that is none of them."""
        names = {option.name for option in fields(cls)}
        for name in options:
            if name not in names:
                expert = {option.name for option in fields(ProcessOptions)}
                hint = f" (an expert argument: processes=ProcessOptions({name}=...))" if name in expert else ""
                raise TypeError(f"unexpected keyword argument {name!r}{hint}")
        given: dict[str, Any] = dict(options)
        for name in ("airframe", "folder"):
            if given.get(name) is not None:
                given[name] = Path(given[name])
        if "params" in given:
            given["params"] = dict(given["params"] or {})
        if "spawn_alt" in given:
            given["spawn_alt"] = float(given["spawn_alt"])
        if given.get("speed") == 0:
            given["speed"] = None
        if "processes" in given and not isinstance(given["processes"], ProcessOptions):
            raise TypeError(f"processes must be a ProcessOptions, not {type(given['processes']).__name__}")
        return cls(**given)

    def check(self, count: int) -> None:
        """Raise ValueError naming the first bad argument."""
        if count < 1:
            raise ValueError(f"count must be at least 1, not {count}")
        if self.controller not in ("mpc", "pid"):
            raise ValueError(f"controller must be 'mpc' or 'pid', not {self.controller!r}")
        if not (math.isfinite(self.spawn_alt) and self.spawn_alt >= 0):
            raise ValueError(f"spawn_alt must be a finite number of metres >= 0, not {self.spawn_alt!r}")
        if self.speed is not None and not (math.isfinite(self.speed) and self.speed > 0):
            raise ValueError(f"speed must be a factor >= 0 (0 or None: lockstep, as fast as possible), not "
                             f"{self.speed!r}")  # fmt: skip
        if self.instance is not None and not 0 <= self.instance <= 999 - (count - 1):
            raise ValueError(f"instance must be in 0..{999 - (count - 1)}, not {self.instance}")
        if self.sysid is not None and not 1 <= self.sysid <= 250 - (count - 1):
            raise ValueError(f"sysid must be in 1..{250 - (count - 1)}, not {self.sysid}")
        if self.gcs_port is not None and not 1 <= self.gcs_port <= 65535:
            raise ValueError(f"gcs_port must be a UDP port 1..65535, not {self.gcs_port}")
        if self.gcs_bind is not None:
            try:
                ipv4_address(self.gcs_bind)
            except ArgumentTypeError as refusal:
                raise ValueError(f"gcs_bind: {refusal}") from None
        if self.airframe is not None and not Path(self.airframe).is_file():
            raise ValueError(f"airframe: no such file: {self.airframe}")
        if self.home is not None and not (-90 <= self.home.lat <= 90 and -180 <= self.home.lon <= 180):
            raise ValueError(f"home latitude/longitude out of range: {self.home}")
        if self.link_faults is not None and not isinstance(self.link_faults, Faults):
            raise ValueError(f"link_faults must be a Faults, not {self.link_faults!r}")
        if self.link_faults is not None and not self.processes.autopilot:
            raise ValueError("link_faults with autopilot=False: no ground-station link is started")
        self.processes.check(count)
        store = ParameterStore(None)
        for name, value in self.params.items():
            try:
                definition = store.check(name, float(value))
            except ParameterRejected as refusal:
                raise ValueError(f"params: {refusal}") from None
            if definition.plant:
                raise ValueError(f"params: {name} is the plant's (the wind): give wind=Wind(...)")
        if self.wind is not None:
            if not isinstance(self.wind, Wind):
                raise ValueError(f"wind must be a tiltrotor_sitl.Wind, not {self.wind!r}")
            self.wind.check()
            if not self.starts_plant:
                raise ValueError("wind with plant_port: no plant is started (the wind is the plant's)")

    @property
    def starts_plant(self) -> bool:
        return self.processes.plant_port is None

    @property
    def params_file(self) -> Path | None:
        file = self.processes.params_file
        return None if file is None else Path(file)

    def first_sysid(self) -> int:
        """The first vehicle's system id: sysid, else MAV_SYS_ID as params or an existing params_file set it,
        else the instance's (I + 1), else 1 (free ports)."""
        if self.sysid is not None:
            return self.sysid
        store = ParameterStore(self.params_file)
        try:
            store.load()
        except ParameterFileError as exc:
            raise ValueError(f"params_file: {exc}") from None
        for name, value in self.params.items():
            store.set(name, float(value))
        return vehicle_system_id(store, self.instance or 0)


@dataclass
class Started:
    """One running vehicle: its system id, ports (as its ground stations see them), processes, folder, truth feed and
    the fault proxies on its ground-station links (with link_faults)."""

    sysid: int
    ports: VehiclePorts
    home: Home
    children: list[Child]
    folder: Path
    params_path: Path
    truth: TruthFeed | None = None
    proxies: list[FaultProxy] = field(default_factory=list)  # the GCS link's, then the API link's


def _vehicle_ports(options: Options, index: int, gcs_remote: int) -> VehiclePorts:
    if options.instance is None:
        ports = VehiclePorts.free()
    else:
        ports = VehiclePorts.of_instance(options.instance + index)
    links = ports.links
    plant = ports.plant if options.starts_plant else options.processes.plant_port
    return VehiclePorts(plant, LinkPorts(links.gcs_bind, gcs_remote, links.api_bind, links.api_remote),
                        ports.zenoh_plant, ports.zenoh_autopilot)  # fmt: skip


def _check_free(options: Options, ports: VehiclePorts, sysid: int) -> None:
    """VehicleError if a port a process of this vehicle binds is taken."""
    udp, tcp = [], []
    if options.starts_plant:
        udp.append(("the plant link", ports.plant))
        tcp.append(("the plant's zenoh", ports.zenoh_plant))
    if options.processes.autopilot:
        udp += [("the GCS link", ports.links.gcs_bind), ("the API link", ports.links.api_bind)]
        tcp.append(("the autopilot's zenoh", ports.zenoh_autopilot))
    checks = [(name, port, socket.SOCK_DGRAM) for name, port in udp]
    checks += [(name, endpoint_port(endpoint), socket.SOCK_STREAM) for name, endpoint in tcp]
    for name, port, kind in checks:
        error = bind_error(kind, port)
        if error is not None:
            raise VehicleError(f"vehicle {sysid}: cannot bind {protocol(kind).upper()} port {LOOPBACK}:{port} ({name}): "
                               f"{error.strerror}; another vehicle on this instance? use free ports (instance=None) or "
                               f"another instance")  # fmt: skip


def _write_params(path: Path, params: dict[str, float]) -> Path:
    """Write `params` into the parameter file `path` (what an existing file holds is kept, as the autopilot would)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    store = ParameterStore(path)
    if path.exists():
        store.load()
        if not params:
            return path
    for name, value in params.items():
        store.set(name, float(value))
    error = store.flush()
    if error:
        raise VehicleError(f"cannot write the parameter file {path}: {error}")
    return path


def _link_proxies(faults: Faults | None, links: LinkPorts, sysid: int) -> list[FaultProxy]:
    """With link faults: a seeded fault proxy in front of each ground-station port (the GCS link's, then the API
    link's), started; the vehicle is their client, its ground stations their target."""
    if faults is None:
        return []
    proxies = [
        FaultProxy(links.gcs_remote, faults, seed=sysid),
        FaultProxy(links.api_remote, faults, seed=sysid + 1000),
    ]
    return [proxy.start() for proxy in proxies]


def _autopilot_links(links: LinkPorts, proxies: list[FaultProxy]) -> LinkPorts:
    """Where the autopilot's links send: its ground stations' ports, or the fault proxies in front of them."""
    if not proxies:
        return links
    gcs, api = proxies
    return LinkPorts(links.gcs_bind, gcs.port, links.api_bind, api.port)


def _prepare(options: Options, index: int, sysid: int, ports: VehiclePorts, root: Path) -> Started:
    """A vehicle's folder, parameter file and, with link faults, its running fault proxies."""
    folder = root / f"vehicle-{sysid}"
    folder.mkdir()
    home = fleet_home(index, options.home) if index > 0 else (options.home or home_from(None, os.environ))
    params_path = _write_params(options.params_file or folder / "params.json", options.params)
    started = Started(sysid, ports, home, [], folder, params_path)
    if options.processes.autopilot:
        started.proxies = _link_proxies(options.link_faults, ports.links, sysid)
    return started


def _start_processes(options: Options, started: Started) -> None:
    """Start the vehicle's plant and autopilot (those the options ask for), each appended to its children."""
    ports, processes = started.ports, options.processes
    plant_zenoh = Zenoh.listening(ports.zenoh_plant) if options.truth else Zenoh.off()
    autopilot_zenoh = Zenoh.listening(ports.zenoh_autopilot) if options.truth else Zenoh.off()
    if options.starts_plant:
        plant = SimCommand(port=ports.plant, spawn_alt=options.spawn_alt, realtime_speed=options.speed,
                           duration_s=processes.duration_s, zenoh=plant_zenoh, airframe=options.airframe,
                           sysid=started.sysid, home=started.home, summary=processes.summary,
                           extra=tuple(processes.plant_args), **plant_wind(options.wind))  # fmt: skip
        started.children.append(_start_child("vtol-sim", plant.argv(), started.folder))
    if processes.autopilot:
        autopilot = AutopilotCommand(sim_port=ports.plant, links=_autopilot_links(ports.links, started.proxies),
                                     gcs_bind=options.gcs_bind,
                                     spawn_alt=options.spawn_alt, controller=options.controller,
                                     params=started.params_path, root=started.folder, airframe=options.airframe,
                                     duration_s=processes.duration_s, zenoh=autopilot_zenoh, sysid=started.sysid,
                                     home=started.home, summary=processes.summary,
                                     extra=tuple(processes.autopilot_args))  # fmt: skip
        started.children.append(_start_child("vtol-autopilot", autopilot.argv(), started.folder))


def _start_child(name: str, argv: list[str], folder: Path) -> Child:
    """One process of a vehicle, deterministic, with stdout in folder/<name>.stdout and stderr in folder/<name>.stderr
    (so a process that dies during start-up can be quoted and a --summary line read back), in its own process group
    and killed when this process dies."""
    return _children.start(name, argv, stdout=folder / f"{name}.stdout", stderr=folder / f"{name}.stderr",
                           env={"PYTHONUNBUFFERED": "1"}, deterministic=True, own_group=True,
                           parent_death=signal.SIGKILL)  # fmt: skip


def _wait_listening(plants: list[Started], timeout_s: float, keep_going: Callable[[], None]) -> bool:
    """Wait until every plant has said on stderr that it listens on its port (the plant alone: nobody steps it, so
    there is no readiness to arm to wait for)."""
    deadline = time.monotonic() + timeout_s
    while not all(PLANT_LISTENING in child.stderr_text()
                  for vehicle in plants for child in vehicle.children):  # fmt: skip
        keep_going()
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def _watch(options: Options, vehicles: list[Started]) -> ReadinessWatch | None:
    """A watch on the GCS port the vehicles send to; if it is taken (a ground station already there), on their
    API ports instead."""
    if not options.processes.autopilot:
        return None
    sysids = [vehicle.sysid for vehicle in vehicles]
    gcs = vehicles[0].ports.links.gcs_remote
    try:
        return ReadinessWatch([gcs], sysids)
    except OSError:
        pass
    api = [vehicle.ports.links.api_remote for vehicle in vehicles]
    try:
        return ReadinessWatch(api, sysids)
    except OSError as exc:
        raise VehicleError(f"cannot watch for readiness: UDP {LOOPBACK}:{gcs} (where the vehicles' GCS links send) "
                           f"and their API ports {api} are in use ({exc.strerror})") from None  # fmt: skip


def launch(options: Options, count: int) -> tuple[list[Started], Path, float]:
    """Start `count` vehicles and wait until each is ready to arm: (vehicles, their folder, seconds to ready).
    On any failure everything started is stopped and VehicleError (or ValueError for a bad argument) raised."""
    options.check(count)
    began = time.monotonic()
    first = options.first_sysid()
    default_gcs = Ports(0).gcs_remote if options.instance is not None else None
    gcs_remote = options.gcs_port or default_gcs or free_udp_port()
    plan = [(first + i, _vehicle_ports(options, i, gcs_remote)) for i in range(count)]
    for sysid, ports in plan:
        _check_free(options, ports, sysid)
    root = Path(tempfile.mkdtemp(prefix="tiltrotor-sitl-")) if options.folder is None else options.folder
    root.mkdir(parents=True, exist_ok=True)
    vehicles: list[Started] = []
    watch: ReadinessWatch | None = None
    try:
        watch_started = [Started(sysid, ports, Home(), [], root, root) for sysid, ports in plan]
        watch = _watch(options, watch_started)
        for index, (sysid, ports) in enumerate(plan):
            vehicles.append(_prepare(options, index, sysid, ports, root))
            _start_processes(options, vehicles[-1])

        def keep_going() -> None:
            for vehicle in vehicles:
                for child in vehicle.children:
                    if not child.running():
                        raise VehicleError(f"vehicle {vehicle.sysid}: {child.describe_exit('during start-up')}")

        timeout_s = options.processes.ready_timeout_s
        if options.processes.wait_ready:
            if watch is not None:
                ready, missing = watch.wait(timeout_s, keep_going), watch.missing
            else:
                ready, missing = _wait_listening(vehicles, timeout_s, keep_going), _not_listening
            if not ready:
                tails = "\n".join(f"--- vehicle {v.sysid} {c.name} (pid {c.pid}) stderr:\n{c.stderr_tail()}"
                                  for v in vehicles for c in v.children)  # fmt: skip
                what = "ready to arm" if watch is not None else "listening"
                raise VehicleError(f"not {what} within {timeout_s:g} s ({missing()})\n{tails}")
        ready_s = time.monotonic() - began
        if options.truth and options.starts_plant:
            for vehicle in vehicles:
                vehicle.truth = TruthFeed(vehicle.ports.zenoh_plant, vehicle.sysid)
    except BaseException:
        stop(vehicles, root if options.folder is None else None)
        raise
    finally:
        if watch is not None:
            watch.close()
    return vehicles, root, ready_s


def _not_listening() -> str:
    return f"no plant said {PLANT_LISTENING!r} on stderr"


def stop(vehicles: list[Started], remove: Path | None) -> None:
    """Close the truth feeds, stop every process (by PID), then the fault proxies, remove the folder `remove` (a
    temporary one)."""
    for vehicle in vehicles:
        if vehicle.truth is not None:
            vehicle.truth.close()
            vehicle.truth = None
    children = [child for vehicle in vehicles for child in vehicle.children]
    _children.stop([child for child in children if child.name == "vtol-autopilot"])  # the controllers first,
    _children.stop([child for child in children if child.name != "vtol-autopilot"])  # then the plants
    for vehicle in vehicles:
        for proxy in vehicle.proxies:
            proxy.stop()
    if remove is not None:
        shutil.rmtree(remove, ignore_errors=True)
