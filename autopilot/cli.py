"""`vtol-autopilot`: the autopilot process: the flight stack on the plant link, MAVLink services for ground stations."""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

from aircraft.airframe import AirframeError, load_airframe
from aircraft.failures import FailureRejected, parse_failure
from autopilot.commander.calibration import Calibration
from autopilot.commander.commander import build_commander
from autopilot.commander.failure_injection import FailureInjection, ScheduledFailure
from autopilot.commander.flight_stack import FlightStack
from autopilot.commander.guided_requests import GuidedRequests
from autopilot.commander.output_requests import OutputRequests
from autopilot.control.flight_controller import FlightController
from autopilot.controllers import build_flight_controller, controller_kind, mpc_horizon
from autopilot.logger.control_telemetry import ControlTelemetry
from autopilot.logger.flight_log import FlightLogger
from autopilot.logger.logger import Logger, VehicleIdentity
from autopilot.mavlink.component_metadata import METADATA
from autopilot.mavlink.ftp_protocol import FileRoot
from autopilot.mavlink.router import GroundLink, Router
from autopilot.mavlink.services import MavlinkServices
from autopilot.mpc.horizon import HORIZONS
from autopilot.plant_loop import LoopOutputs, PlantLoop
from autopilot.reboot import execute_again, reboot_argv, said_sysid
from autopilot.storage.mission_store import MissionFileError, MissionStore, default_mission_path
from autopilot.storage.parameters import ParameterFileError, ParameterStore, default_parameter_path, vehicle_system_id
from autopilot.storage.vehicle_files import VehicleFiles, default_root
from autopilot.topics.vehicle_status import EventOutbox
from scenarios.profiles import PROFILES
from transport.cli import (
    OneLineArgumentParser,
    bounded_int,
    fail,
    finite_float,
    float_triple,
    ipv4_address,
    key_file_option,
    nonnegative_float,
    positive_float,
    stop_on_signals,
)
from transport.geodesy import HomeRefused, home_from
from transport.mavlink import mavlink
from transport.plant_link import PlantLinkClient
from transport.ports import LOOPBACK, Ports
from transport.telemetry import autopilot_events_key
from transport.zenoh_bus import open_session

PROG = "vtol-autopilot"


def scheduled_failure(text: str) -> ScheduledFailure:
    """'T,UNIT,TYPE,INSTANCE[,VALUE]' -> ScheduledFailure (VALUE may be nan)."""
    parts = text.split(",")
    if len(parts) not in (4, 5):
        raise argparse.ArgumentTypeError(f"expected T,UNIT,TYPE,INSTANCE[,VALUE]: {text!r}")
    try:
        time_s = finite_float(parts[0])
        unit, kind, instance = (float(p) for p in parts[1:4])
        value = float(parts[4]) if len(parts) == 5 else float("nan")
    except ValueError:
        raise argparse.ArgumentTypeError(f"not numbers: {text!r}") from None
    try:
        return ScheduledFailure(time_s, parse_failure(unit, kind, instance, value))
    except FailureRejected as refusal:
        raise argparse.ArgumentTypeError(f"{refusal}: {text!r}") from None


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog=PROG, description="Tilt-rotor VTOL autopilot: flies the plant over MAVLink "
                                   "and is a PX4-like MAVLink vehicle for ground stations.")  # fmt: skip
    port = bounded_int(1, 65535)
    parser.add_argument("--instance", type=bounded_int(0, 999), default=0, metavar="I", help="shift every port by I")
    parser.add_argument("--sim-port", type=port, metavar="P", help="the plant's UDP port (default 4560+I)")
    parser.add_argument(
        "--sim-bind-port",
        type=port,
        default=0,
        metavar="P",
        help="bind the plant link to UDP P (default: any free port; for vtol-sim --autopilot-port P)",
    )
    parser.add_argument("--gcs-port", type=port, metavar="P", help="GCS link: bind UDP P (default 18570+I)")
    parser.add_argument("--gcs-bind", type=ipv4_address, default=LOOPBACK, metavar="ADDR",
                        help="GCS link: listen on this IPv4 address (default 127.0.0.1; 0.0.0.0: every interface, "
                             "for a ground station on another machine)")  # fmt: skip
    parser.add_argument(
        "--gcs-remote-port",
        type=port,
        metavar="P",
        help="GCS link: send to 127.0.0.1:P until a client speaks (default 14550, every instance)",
    )
    parser.add_argument("--api-port", type=port, metavar="P", help="API (offboard) link: bind UDP P (default 14580+I)")
    parser.add_argument(
        "--api-remote-port",
        type=port,
        metavar="P",
        help="API link: send to 127.0.0.1:P until a client speaks (default 14540+I)",
    )
    parser.add_argument("--controller", choices=("pid", "mpc"),
                        help="velocity controller: mpc (the unified MPC, the PID its back-up) or pid (the baseline); "
                             "default: the VT_CTRL parameter (1 = mpc)")  # fmt: skip
    parser.add_argument("--mpc-horizon", choices=sorted(HORIZONS),
                        help="the MPC's horizon: paper (25 x 10 ms) or long (2.05 s, non-uniform); "
                             "default: the VT_MPC_HRZN parameter")  # fmt: skip
    parser.add_argument("--params", metavar="FILE",
                        help="parameter file (default $XDG_STATE_HOME/tiltrotor-sitl/params-I.json, "
                             "~/.local/state when unset)")  # fmt: skip
    parser.add_argument("--missions", metavar="FILE",
                        help="mission file: mission, geofence and rally points, kept across restarts (default "
                             "missions-I.json beside the parameter file)")  # fmt: skip
    parser.add_argument("--airframe", metavar="FILE", help="airframe TOML for the controllers' model")
    parser.add_argument(
        "--spawn-alt",
        type=nonnegative_float,
        default=0.0,
        metavar="M",
        help="the plant spawned hovering: start armed, in Hold (0 = on the ground, disarmed)",
    )
    parser.add_argument("--profile", choices=sorted(PROFILES),
                        help="fly an internal velocity set-point profile (docs/scenarios.md) from the first step "
                             "instead of taking commands")  # fmt: skip
    parser.add_argument("--offboard-lockstep", action="store_true",
                        help="deterministic scripted flights: Offboard set-points take effect at their time_boot_ms "
                             "stamp, and the simulation (in every mode, from the first step) advances only as far "
                             "as a client's stamped set-points reach (docs/mavlink.md)")  # fmt: skip
    parser.add_argument("--duration", type=positive_float, metavar="S", help="stop after S simulated seconds")
    parser.add_argument(
        "--failure",
        type=scheduled_failure,
        action="append",
        default=[],
        metavar="T,UNIT,TYPE,INSTANCE[,VALUE]",
        help="inject MAV_CMD_INJECT_FAILURE at simulated time T (repeatable)",
    )
    parser.add_argument("--log", metavar="FILE.csv", help="write the 100 Hz flight log (state, set-points, actuators)")
    parser.add_argument("--root", metavar="DIR",
                        help="the vehicle's file root, PX4's /fs/microsd: its ULogs in DIR/log/, served by MAVLink FTP "
                             "(default microsd-I beside the parameter file)")  # fmt: skip
    parser.add_argument(
        "--log-dir",
        metavar="DIR",
        help="write the ULogs to DIR/YYYY-MM-DD/HH_MM_SS.ulg (default ROOT/log; SDLOG_MODE says when)",
    )
    parser.add_argument("--no-ulog", action="store_true", help="write no ULog (log download and FTP still served)")
    parser.add_argument(
        "--sysid",
        type=bounded_int(1, 250),
        metavar="N",
        help="vehicle system id (default: MAV_SYS_ID when set in the parameter file, else I+1)",
    )
    parser.add_argument(
        "--home",
        type=float_triple,
        default=None,
        metavar="LAT,LON,ALT",
        help="home position in degrees and metres AMSL, as the plant's --home "
        "(default PX4 SITL's 47.397742,8.545594,488, or PX4_HOME_LAT/LON/ALT)",
    )
    parser.add_argument("--no-zenoh", action="store_true", help="do not publish telemetry on zenoh")
    parser.add_argument(
        "--zenoh-listen",
        action="append",
        metavar="ENDPOINT",
        help="zenoh endpoint to listen on (default tcp/127.0.0.1:7547+I); repeatable",
    )
    parser.add_argument(
        "--zenoh-connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="zenoh endpoint to connect to; repeatable",
    )
    parser.add_argument("--quiet", action="store_true", help="do not echo flight events (STATUSTEXT) on stderr")
    parser.add_argument(
        "--plant-signing-key",
        metavar="FILE",
        help="sign the plant link with this key (64 hex digits), as the plant's --plant-signing-key",
    )
    parser.add_argument("--summary", action="store_true", help="print a JSON line of counters on exit")
    return parser


def serve_files(files: VehicleFiles, params_path: Path, missions_path: Path | None) -> FileRoot:
    """The vehicle's root made ready for MAVLink FTP: its folders, the component metadata in etc/extras; what FTP
    may not change (the files the autopilot keeps)."""
    try:
        files.log_dir.mkdir(parents=True, exist_ok=True)
        written = METADATA.write(files.extras)
    except OSError as exc:
        fail(PROG, f"cannot prepare the vehicle's files in {files.root}: {exc.strerror or exc}")
    protected = {params_path.absolute(), files.extras, *written}
    if missions_path is not None:
        protected.add(missions_path.absolute())
    return FileRoot(files.root, files.log_dir, frozenset(protected))


def open_link(name: str, bind_port: int, remote_port: int, system_id: int, *, onboard: bool = False,
              bind_address: str = LOOPBACK) -> GroundLink:  # fmt: skip
    try:
        return GroundLink(name, bind_port, remote_port, system_id, onboard=onboard, bind_address=bind_address)
    except OSError as exc:
        fail(PROG, f"cannot bind UDP {bind_address}:{bind_port} ({name} link): {exc.strerror}")


def main(argv: list[str] | None = None) -> int:
    arguments = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(arguments)
    if args.profile and args.offboard_lockstep:
        fail(PROG, "--profile flies the internal set-points: it does not go with --offboard-lockstep")
    try:
        airframe = load_airframe(args.airframe)
    except AirframeError as exc:
        fail(PROG, str(exc))
    try:
        home = home_from(args.home, os.environ)
    except HomeRefused as exc:
        fail(PROG, f"home refused: {exc}")
    ports = Ports(args.instance)
    params = ParameterStore(Path(args.params) if args.params else default_parameter_path(args.instance))
    try:
        params.load()
    except ParameterFileError as exc:
        fail(PROG, str(exc))
    for warning in params.warnings:
        print(f"{PROG}: warning: {warning}", file=sys.stderr)
    assert params.path is not None
    missions = MissionStore(Path(args.missions) if args.missions else default_mission_path(params.path, args.instance))
    try:
        missions.load()
    except MissionFileError as exc:
        fail(PROG, str(exc))
    system_id = args.sysid if args.sysid is not None else vehicle_system_id(params, args.instance)
    files = VehicleFiles.at(Path(args.root) if args.root else default_root(params.path, args.instance),
                            Path(args.log_dir) if args.log_dir else None)  # fmt: skip
    file_root = serve_files(files, params.path, missions.path)
    sim_port = args.sim_port if args.sim_port is not None else ports.plant
    router = Router([
        open_link("GCS", args.gcs_port or ports.gcs_bind, args.gcs_remote_port or ports.gcs_remote, system_id,
                  bind_address=args.gcs_bind),
        open_link("API", args.api_port or ports.api_bind, args.api_remote_port or ports.api_remote, system_id,
                  onboard=True),
    ])  # fmt: skip
    stop_requested = stop_on_signals()
    in_air = args.spawn_alt > 0
    profile = PROFILES[args.profile][0] if args.profile else None
    events = EventOutbox()
    commander = build_commander(params, airframe.hover_thrust_per_rotor / airframe.thrust_max, armed=in_air, in_air=in_air,
                          say=events.say, profile=profile, stamped_setpoints=args.offboard_lockstep,
                          missions=missions, home=home)  # fmt: skip
    try:
        client = PlantLinkClient(sim_port, system_id=system_id, local_port=args.sim_bind_port,
                                 signing_key=key_file_option(PROG, "--plant-signing-key", args.plant_signing_key),
                                 sensors=False)  # fmt: skip
    except OSError as exc:
        fail(PROG, f"cannot bind the plant link to UDP {LOOPBACK}:{args.sim_bind_port}: {exc.strerror}")
    injection = FailureInjection(send=lambda failure: client.command_plant(mavlink.MAV_CMD_INJECT_FAILURE,
                                                                          failure.as_params()),
                                 note=lambda text: print(f"{PROG}: {text}", file=sys.stderr, flush=True),
                                 scheduled=args.failure)  # fmt: skip
    try:
        log = open(args.log, "w", newline="") if args.log else None  # noqa: SIM115 (closed when the loop ends)
    except OSError as exc:
        fail(PROG, f"cannot write the log {args.log}: {exc.strerror}")
    session = None
    if not args.no_zenoh:
        session = open_session(args.zenoh_listen or [ports.zenoh_autopilot], args.zenoh_connect, PROG)
    ulog = None if args.no_ulog else Logger(
        files, params, commander, missions, injection,
        VehicleIdentity(system_id, home, commander.navigator.ids, airframe.gravity,
                        airframe.thrust_max * len(airframe.rotor_positions)),
    )  # fmt: skip
    calibration = Calibration(params, events.say)
    flight_stack = FlightStack(commander, GuidedRequests(commander), OutputRequests(commander), injection, params,
                               missions, calibration)  # fmt: skip
    services = MavlinkServices(
        router, params, flight_stack, system_id=system_id, home=home, missions=missions.snapshot,
        modes=commander.navigator.ids,
        events_publisher=None if session is None else session.declare_publisher(autopilot_events_key(system_id)),
        quiet=args.quiet, files=file_root, logs=files, statustext_sink=None if ulog is None else ulog.statustext,
        logs_finishing=(lambda: False) if ulog is None else ulog.finishing,
    )  # fmt: skip
    kind = controller_kind(args.controller, params.get_int("VT_CTRL"))

    def new_flight_controller() -> FlightController:
        """Built at start and at every takeoff from the ground, with the parameters of the moment."""
        return build_flight_controller(
            airframe,
            controller_kind(args.controller, params.get_int("VT_CTRL")),
            params,
            mpc_horizon=mpc_horizon(args.mpc_horizon, params.get_int("VT_MPC_HRZN")),
            mpc_overlap=params.get_int("VT_MPC_OVERLAP") == 1,
        )

    outputs = LoopOutputs(
        log=None if log is None else FlightLogger(log),
        telemetry=None if session is None else ControlTelemetry(session, system_id),
        ulog=ulog,
    )
    loop = PlantLoop(airframe, new_flight_controller, client, commander, params, injection, events,
                     services=services, home=home, outputs=outputs, duration_s=args.duration,
                     offboard_lockstep=args.offboard_lockstep,
                     should_stop=lambda: stop_requested() or flight_stack.reboot_requested, missions=missions,
                     calibration=calibration)  # fmt: skip
    gcs, api = router.links
    print(f"{PROG}: {kind} controller, plant link udp {LOOPBACK}:{sim_port}, "
          f"{said_sysid(system_id)}, GCS udp {gcs.bind_address}:{gcs.bind_port} -> {gcs.default_remote[1]}, "
          f"API udp {LOOPBACK}:{api.bind_port} -> {api.default_remote[1]}, "
          f"parameters {params.path}, missions {missions.path}, files {files.root} (logs {files.log_dir})",
          file=sys.stderr, flush=True)  # fmt: skip
    try:
        loop.run()
    finally:
        client.close()
        if ulog is not None:
            ulog.close()
        services.close()
        for error in (params.flush(), missions.flush()):
            if error:
                print(f"{PROG}: {error}", file=sys.stderr)
        if log is not None:
            log.close()
        if session is not None:
            session.close()
    if args.summary:
        print(json.dumps(loop.summary() | ({} if ulog is None else {"ulog": ulog.summary()})), flush=True)
    if flight_stack.reboot_requested and not stop_requested():
        print(f"{PROG}: rebooting", file=sys.stderr, flush=True)
        try:
            execute_again(reboot_argv(arguments, params.set_since_start, client.local_port))
        except OSError as exc:
            fail(PROG, f"cannot reboot (execute {sys.executable}): {exc.strerror or exc}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
