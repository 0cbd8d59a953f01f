"""`vtol-autopilot`: the autopilot process (SPEC sections 1, 2 and 4)."""

from __future__ import annotations

import argparse
import json
import sys

from aircraft.airframe import AirframeError, load_airframe
from autopilot.flight_controller import FlightController
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
from transport.ports import Ports
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
    parser = OneLineArgumentParser(prog=PROG, description="Tilt-rotor VTOL autopilot: flies the plant over MAVLink.")
    parser.add_argument("--instance", type=bounded_int(0, 999), default=0, help="shift every port by I")
    parser.add_argument("--sim-port", type=bounded_int(1, 65535), help="the plant's UDP port (default 4560+I)")
    parser.add_argument("--controller", choices=("mpc", "pid"), default="pid",
                        help="velocity controller: pid (the PX4-style baseline; the MPC arrives with issue 5)")
    parser.add_argument("--airframe", metavar="FILE", help="airframe TOML for the controllers' model")
    parser.add_argument("--spawn-alt", type=nonnegative_float, default=0.0, metavar="M",
                        help="the plant spawned hovering: start armed, holding (0 = on the ground, disarmed)")
    parser.add_argument("--profile", choices=sorted(PROFILES), default="hover",
                        help="internal velocity set-point profile (SPEC section 7) flown from the first step")
    parser.add_argument("--duration", type=positive_float, metavar="S", help="stop after S simulated seconds")
    parser.add_argument("--failure", type=scheduled_failure, action="append", default=[],
                        metavar="T,UNIT,TYPE,INSTANCE[,VALUE]",
                        help="inject MAV_CMD_INJECT_FAILURE at simulated time T (repeatable)")
    parser.add_argument("--log", metavar="FILE.csv", help="write the 100 Hz flight log (state, set-points, actuators)")
    parser.add_argument("--sysid", type=bounded_int(1, 255), default=1, help="vehicle system id (MAV_SYS_ID)")
    parser.add_argument("--no-zenoh", action="store_true", help="do not publish telemetry on zenoh")
    parser.add_argument("--zenoh-listen", action="append", metavar="ENDPOINT",
                        help="zenoh endpoint to listen on (default tcp/127.0.0.1:7547+I); repeatable")
    parser.add_argument("--zenoh-connect", action="append", default=[], metavar="ENDPOINT",
                        help="zenoh endpoint to connect to; repeatable")
    parser.add_argument("--summary", action="store_true", help="print a JSON line of counters on exit")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        airframe = load_airframe(args.airframe)
    except AirframeError as exc:
        fail(PROG, str(exc))
    ports = Ports(args.instance)
    port = args.sim_port if args.sim_port is not None else ports.plant
    profile, _ = PROFILES[args.profile]
    stop_requested = stop_on_signals()
    controller = FlightController(airframe, args.controller)
    client = PlantLinkClient(port, system_id=args.sysid)
    try:
        log = open(args.log, "w", newline="") if args.log else None
    except OSError as exc:
        fail(PROG, f"cannot write the log {args.log}: {exc.strerror}")
    session = None
    if not args.no_zenoh:
        session = open_session(args.zenoh_listen or [ports.zenoh_autopilot], args.zenoh_connect, PROG)
    loop = PlantLoop(
        airframe, controller, client, profile,
        armed=args.spawn_alt > 0, duration_s=args.duration, failures=args.failure, log=log,
        zenoh_session=session, system_id=args.sysid,
        should_stop=stop_requested,
    )  # fmt: skip
    print(f"{PROG}: {args.controller} controller, plant link udp 127.0.0.1:{port}", file=sys.stderr, flush=True)
    try:
        loop.run()
    finally:
        client.close()
        if log is not None:
            log.close()
        if session is not None:
            session.close()
    if args.summary:
        print(json.dumps(loop.summary()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
