"""`vtol-autopilot`: the autopilot process (SPEC sections 1, 2, 4 and 5)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from aircraft.airframe import AirframeError, load_airframe
from autopilot.commander import Commander
from autopilot.controller_choice import ControllerChoice
from autopilot.mavlink_vehicle import GroundLink, MavlinkVehicle
from autopilot.parameters import ParameterFileError, ParameterStore, default_parameter_path
from autopilot.plant_loop import PlantLoop, ScheduledFailure
from autopilot.setpoint_profiles import PROFILES
from transport.cli import (
    OneLineArgumentParser,
    bounded_int,
    fail,
    finite_float,
    nonnegative_float,
    positive_float,
    stop_on_signals,
)
from transport.plant_link import PlantLinkClient
from transport.ports import LOOPBACK, Ports
from transport.zenoh_bus import open_session

PROG = "vtol-autopilot"


def scheduled_failure(text: str) -> ScheduledFailure:
    """'T,UNIT,TYPE,INSTANCE[,VALUE]' -> ScheduledFailure (VALUE may be nan)."""
    parts = text.split(",")
    if len(parts) not in (4, 5):
        raise argparse.ArgumentTypeError(f"expected T,UNIT,TYPE,INSTANCE[,VALUE]: {text!r}")
    try:
        time_s = finite_float(parts[0])
        unit, kind, instance = (int(p) for p in parts[1:4])
        value = float(parts[4]) if len(parts) == 5 else float("nan")
    except ValueError:
        raise argparse.ArgumentTypeError(f"not numbers: {text!r}") from None
    if unit not in (101, 102) or kind not in (0, 1, 2, 4) or not 0 <= instance <= 8:
        raise argparse.ArgumentTypeError(f"unit 101|102, type 0|1|2|4, instance 0..8: {text!r}")
    return ScheduledFailure(time_s, unit, kind, instance, value)


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(prog=PROG, description="Tilt-rotor VTOL autopilot: flies the plant over MAVLink "
                                   "and is a PX4-like MAVLink vehicle for ground stations.")  # fmt: skip
    port = bounded_int(1, 65535)
    parser.add_argument("--instance", type=bounded_int(0, 999), default=0, help="shift every port by I")
    parser.add_argument("--sim-port", type=port, help="the plant's UDP port (default 4560+I)")
    parser.add_argument("--gcs-port", type=port, metavar="P", help="GCS link: bind UDP P (default 18570+I)")
    parser.add_argument("--gcs-remote-port", type=port, metavar="P",
                        help="GCS link: send to 127.0.0.1:P until a client speaks (default 14550+I)")
    parser.add_argument("--api-port", type=port, metavar="P", help="API (offboard) link: bind UDP P (default 14580+I)")
    parser.add_argument("--api-remote-port", type=port, metavar="P",
                        help="API link: send to 127.0.0.1:P until a client speaks (default 14540+I)")
    parser.add_argument("--controller", choices=("pid", "mpc"),
                        help="velocity controller: mpc (the unified MPC, the PID its back-up) or pid (the baseline); "
                             "default: the VT_CTRL parameter (1 = mpc)")  # fmt: skip
    parser.add_argument("--params", metavar="FILE",
                        help="parameter file (default $XDG_STATE_HOME/tiltrotor-sitl/params-I.json, "
                             "~/.local/state when unset)")  # fmt: skip
    parser.add_argument("--airframe", metavar="FILE", help="airframe TOML for the controllers' model")
    parser.add_argument("--spawn-alt", type=nonnegative_float, default=0.0, metavar="M",
                        help="the plant spawned hovering: start armed, in Hold (0 = on the ground, disarmed)")
    parser.add_argument("--profile", choices=sorted(PROFILES),
                        help="fly an internal velocity set-point profile (SPEC section 7) from the first step "
                             "instead of taking commands")  # fmt: skip
    parser.add_argument("--offboard-lockstep", action="store_true",
                        help="deterministic scripted flights: Offboard set-points take effect at their time_boot_ms "
                             "stamp, and the simulation (in every mode, from the first step) advances only as far "
                             "as a client's stamped set-points reach (docs/mavlink.md)")  # fmt: skip
    parser.add_argument("--duration", type=positive_float, metavar="S", help="stop after S simulated seconds")
    parser.add_argument("--failure", type=scheduled_failure, action="append", default=[],
                        metavar="T,UNIT,TYPE,INSTANCE[,VALUE]",
                        help="inject MAV_CMD_INJECT_FAILURE at simulated time T (repeatable)")
    parser.add_argument("--log", metavar="FILE.csv", help="write the 100 Hz flight log (state, set-points, actuators)")
    parser.add_argument("--sysid", type=bounded_int(1, 250), help="vehicle system id (default: MAV_SYS_ID, 1)")
    parser.add_argument("--no-zenoh", action="store_true", help="do not publish telemetry on zenoh")
    parser.add_argument("--zenoh-listen", action="append", metavar="ENDPOINT",
                        help="zenoh endpoint to listen on (default tcp/127.0.0.1:7547+I); repeatable")
    parser.add_argument("--zenoh-connect", action="append", default=[], metavar="ENDPOINT",
                        help="zenoh endpoint to connect to; repeatable")
    parser.add_argument("--quiet", action="store_true", help="do not echo flight events (STATUSTEXT) on stderr")
    parser.add_argument("--summary", action="store_true", help="print a JSON line of counters on exit")
    return parser


def open_link(name: str, bind_port: int, remote_port: int, system_id: int) -> GroundLink:
    try:
        return GroundLink(name, bind_port, remote_port, system_id)
    except OSError as exc:
        fail(PROG, f"cannot bind UDP {LOOPBACK}:{bind_port} ({name} link): {exc.strerror}")


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.profile and args.offboard_lockstep:
        fail(PROG, "--profile flies the internal set-points: it does not go with --offboard-lockstep")
    try:
        airframe = load_airframe(args.airframe)
    except AirframeError as exc:
        fail(PROG, str(exc))
    ports = Ports(args.instance)
    params = ParameterStore(Path(args.params) if args.params else default_parameter_path(args.instance))
    try:
        params.load()
    except ParameterFileError as exc:
        fail(PROG, str(exc))
    for warning in params.warnings:
        print(f"{PROG}: warning: {warning}", file=sys.stderr)
    system_id = args.sysid if args.sysid is not None else params.get_int("MAV_SYS_ID")
    sim_port = args.sim_port if args.sim_port is not None else ports.plant
    links = [
        open_link("GCS", args.gcs_port or ports.gcs_bind, args.gcs_remote_port or ports.gcs_remote, system_id),
        open_link("API", args.api_port or ports.api_bind, args.api_remote_port or ports.api_remote, system_id),
    ]
    stop_requested = stop_on_signals()
    in_air = args.spawn_alt > 0
    profile = PROFILES[args.profile][0] if args.profile else None
    commander = Commander(params, airframe.hover_thrust_per_rotor / airframe.thrust_max, armed=in_air, in_air=in_air,
                          profile=profile, stamped_setpoints=args.offboard_lockstep)  # fmt: skip
    client = PlantLinkClient(sim_port, system_id=system_id)
    try:
        log = open(args.log, "w", newline="") if args.log else None
    except OSError as exc:
        fail(PROG, f"cannot write the log {args.log}: {exc.strerror}")
    session = None
    if not args.no_zenoh:
        session = open_session(args.zenoh_listen or [ports.zenoh_autopilot], args.zenoh_connect, PROG)
    vehicle = MavlinkVehicle(links, params, commander, system_id=system_id, zenoh_session=session, quiet=args.quiet)
    choice = ControllerChoice(airframe, params, args.controller,
                              say=lambda text: vehicle.announce(4, text, key="controller"))  # fmt: skip
    loop = PlantLoop(
        airframe, choice.build(), client, commander,
        controller_factory=choice.build, vehicle=vehicle, params=params,
        duration_s=args.duration, failures=args.failure, log=log,
        zenoh_session=session, system_id=system_id,
        should_stop=stop_requested,
    )  # fmt: skip
    vehicle.inject_failure = loop.request_failure
    vehicle.parameter_changed = loop.parameter_changed
    print(f"{PROG}: {choice.flying} controller, plant link udp {LOOPBACK}:{sim_port}, "
          f"GCS udp {LOOPBACK}:{links[0].bind_port} -> {links[0].default_remote[1]}, "
          f"API udp {LOOPBACK}:{links[1].bind_port} -> {links[1].default_remote[1]}, "
          f"parameters {params.path}", file=sys.stderr, flush=True)  # fmt: skip
    try:
        loop.run()
    finally:
        client.close()
        vehicle.close()
        error = params.flush()
        if error:
            print(f"{PROG}: {error}", file=sys.stderr)
        if log is not None:
            log.close()
        if session is not None:
            session.close()
    if args.summary:
        print(json.dumps(loop.summary()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
