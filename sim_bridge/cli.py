"""`vtol-sim`: the plant process, the vehicle model behind its MAVLink link (docs/model.md, docs/plant-link.md)."""

from __future__ import annotations

import argparse
import json
import os
import socket
import sys

from aircraft.airframe import AirframeError, load_airframe
from sim_bridge.plant import Plant, Spawn
from sim_bridge.plant_parameters import PlantParameterService
from sim_bridge.sensors import SensorSuite
from sim_bridge.server import Pacing, PlantServer
from transport.cli import (
    OneLineArgumentParser,
    bounded_int,
    fail,
    finite_float,
    float_triple,
    key_file_option,
    nonnegative_float,
    positive_float,
    stop_on_signals,
)
from transport.geodesy import HomeRefused, LocalGeodetic, home_from
from transport.mavlink import Link
from transport.mavlink_frames import PLANT_STEP_FORMATS
from transport.plant_parameters import BY_NAME as PLANT_PARAMETER
from transport.plant_parameters import INT32, refusal
from transport.ports import LOOPBACK, Ports
from transport.zenoh_bus import open_session

PROG = "vtol-sim"


def plant_parameter(name: str):
    """An argparse type for the plant parameter `name`'s values (transport/plant_parameters.py)."""
    parameter = PLANT_PARAMETER[name]

    def parse(text: str) -> float | int:
        value = finite_float(text)
        if (why := refusal(parameter, value)) is not None:
            raise argparse.ArgumentTypeError(why)
        return int(value) if parameter.kind == INT32 else value

    return parse


def build_parser() -> OneLineArgumentParser:
    parser = OneLineArgumentParser(
        prog=PROG,
        description="Tilt-rotor VTOL plant: 6-DOF physics behind a MAVLink UDP link (lockstep by default).",
    )
    parser.add_argument("--instance", type=bounded_int(0, 999), default=0, metavar="I",
                        help="shift every port by I (default 0)")  # fmt: skip
    parser.add_argument("--port", type=bounded_int(1, 65535), metavar="P", help="plant link UDP port (default 4560+I)")
    parser.add_argument("--autopilot-port", type=bounded_int(1, 65535), metavar="P",
                        help="belong only to the autopilot on udp 127.0.0.1:P (default: the first autopilot to "
                             "complete the handshake)")  # fmt: skip
    parser.add_argument(
        "--spawn-alt",
        type=nonnegative_float,
        default=0.0,
        metavar="M",
        help="start hovering at M metres (rotors at hover trim); 0 = on the ground, disarmed",
    )
    parser.add_argument(
        "--spawn-rotors",
        choices=("spinning", "stopped"),
        default="spinning",
        help="with --spawn-alt: rotors at hover trim (default) or stopped (a drop test)",
    )
    parser.add_argument(
        "--spawn-yaw",
        type=finite_float,
        default=0.0,
        metavar="DEG",
        help="initial heading in degrees (default 0, north)",
    )
    parser.add_argument("--realtime", action="store_true",
                        help="pace the lockstep to the wall clock times --speed (interactive sessions); when the "
                             "autopilot cannot keep up the simulation slows down, never integrating on a stale "
                             "command")  # fmt: skip
    parser.add_argument("--free-running", action="store_true",
                        help="with --realtime: step on the wall clock with the latest command whatever its age "
                             "(a slow autopilot then flies on stale commands; the vehicle may fall on a busy "
                             "machine)")  # fmt: skip
    parser.add_argument(
        "--speed",
        type=positive_float,
        default=1.0,
        metavar="F",
        help="with --realtime: simulated seconds per wall second (default 1)",
    )
    parser.add_argument("--airframe", metavar="FILE", help="airframe TOML file (default: the paper's vehicle)")
    parser.add_argument(
        "--sysid",
        type=bounded_int(1, 255),
        default=None,
        metavar="N",
        help="vehicle system id (default I+1, as the autopilot's)",
    )
    parser.add_argument("--compid", type=bounded_int(1, 255), default=200, metavar="N",
                        help="plant component id (default 200)")  # fmt: skip
    parser.add_argument(
        "--home",
        type=float_triple,
        default=None,
        metavar="LAT,LON,ALT",
        help="home position in degrees and metres AMSL "
        "(default PX4 SITL's 47.397742,8.545594,488, or PX4_HOME_LAT/LON/ALT)",
    )
    parser.add_argument(
        "--wind",
        type=float_triple,
        default=(0.0, 0.0, 0.0),
        metavar="N,E,D",
        help="the mean wind's velocity in NED, the way the air moves, m/s (default 0,0,0; the horizontal part is the "
        "SIH_WIND_N, SIH_WIND_E parameters, negated: PX4's SIH gives where the wind comes from)",
    )
    parser.add_argument(
        "--wind-turbulence",
        type=plant_parameter("SIM_WIND_TURB"),
        default=0.0,
        metavar="SIGMA",
        help="Dryden turbulence: the vertical gusts' standard deviation, m/s (default 0: none; SIM_WIND_TURB)",
    )
    parser.add_argument(
        "--wind-seed",
        type=plant_parameter("SIM_WIND_SEED"),
        default=0,
        metavar="N",
        help="the turbulence's random seed (default 0; SIM_WIND_SEED)",
    )
    parser.add_argument(
        "--lockstep-timeout",
        type=positive_float,
        default=0.5,
        metavar="S",
        help="wall seconds to wait for the autopilot's command before holding the last one",
    )
    parser.add_argument(
        "--peer-lost-after",
        type=bounded_int(1, 1_000_000),
        default=10,
        metavar="N",
        help="lockstep: after N missed commands in a row, pause until an autopilot speaks (default 10)",
    )
    parser.add_argument(
        "--duration",
        type=positive_float,
        default=None,
        metavar="S",
        help="stop after S simulated seconds (default: run until stopped)",
    )
    parser.add_argument(
        "--sensor-noise-seed",
        type=bounded_int(0, 2**31 - 1),
        default=None,
        metavar="N",
        help="add seeded sensor noise (default: none, runs repeat exactly)",
    )
    parser.add_argument("--no-zenoh", action="store_true", help="do not publish telemetry on zenoh")
    parser.add_argument(
        "--zenoh-listen",
        action="append",
        metavar="ENDPOINT",
        help="zenoh endpoint to listen on (default tcp/127.0.0.1:7447+I); repeatable",
    )
    parser.add_argument(
        "--zenoh-connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="zenoh endpoint to connect to; repeatable",
    )
    parser.add_argument(
        "--plant-signing-key",
        metavar="FILE",
        help="sign the plant link with this key (64 hex digits) and obey only frames signed with it; "
        "give the autopilot the same file",
    )
    parser.add_argument(
        "--summary", action="store_true", help="print a JSON line of counters (steps, missed, dropped...) on exit"
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.speed != 1.0 and not args.realtime:
        fail(PROG, "--speed only applies with --realtime")
    if args.free_running and not args.realtime:
        fail(PROG, "--free-running only applies with --realtime")
    pacing = Pacing.LOCKSTEP
    if args.realtime:
        pacing = Pacing.FREE_RUNNING if args.free_running else Pacing.PACED
    try:
        airframe = load_airframe(args.airframe)
    except AirframeError as exc:
        fail(PROG, str(exc))
    ports = Ports(args.instance)
    port = args.port if args.port is not None else ports.plant
    try:
        home = home_from(args.home, os.environ)
    except HomeRefused as exc:
        fail(PROG, f"home refused: {exc}")

    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((LOOPBACK, port))
    except OSError as exc:
        fail(PROG, f"cannot bind UDP {LOOPBACK}:{port}: {exc.strerror}")
    sock.setblocking(False)

    spawn = Spawn(
        altitude=args.spawn_alt if args.spawn_alt > 0 else None,
        rotors_spinning=args.spawn_rotors == "spinning",
        yaw_deg=args.spawn_yaw,
    )
    link = Link(
        args.sysid if args.sysid is not None else ports.system_id,
        args.compid,
        signing_key=key_file_option(PROG, "--plant-signing-key", args.plant_signing_key),
        fast=PLANT_STEP_FORMATS,
    )
    for name, velocity in (("SIH_WIND_N", args.wind[0]), ("SIH_WIND_E", args.wind[1])):
        if (why := refusal(PLANT_PARAMETER[name], -velocity)) is not None:
            fail(PROG, f"--wind: {why}")
    parameters = PlantParameterService.for_command_line(args.wind, args.wind_turbulence, args.wind_seed, link)
    plant = Plant(airframe, spawn, wind=parameters.wind_model)
    sensors = SensorSuite(plant, link, LocalGeodetic(home), noise_seed=args.sensor_noise_seed)
    session = None
    if not args.no_zenoh:
        session = open_session(args.zenoh_listen or [ports.zenoh_plant], args.zenoh_connect, PROG)

    stop_requested = stop_on_signals()
    server = PlantServer(
        plant, sock, link, sensors,
        pacing=pacing, speed=args.speed, lockstep_timeout_s=args.lockstep_timeout,
        peer_lost_after=args.peer_lost_after,
        duration_s=args.duration, zenoh_session=session, should_stop=stop_requested,
        autopilot=None if args.autopilot_port is None else (LOOPBACK, args.autopilot_port), parameters=parameters,
    )  # fmt: skip
    mode = f"{pacing.value} x{args.speed:g}" if args.realtime else "lockstep"
    print(f"{PROG}: {airframe.name}, {mode}, listening on udp {LOOPBACK}:{port}", file=sys.stderr, flush=True)
    try:
        server.run()
    finally:
        sock.close()
        if session is not None:
            session.close()
    if args.summary:
        print(json.dumps(server.summary()), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
