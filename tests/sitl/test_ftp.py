"""MAVLink FTP on the vehicle's root: MAVSDK's ftp plugin lists it and downloads a log whose CRC32 matches; MAVSDK's
component_metadata plugin fetches the parameter metadata (COMPONENT_METADATA, then FTP), valid against MAVLink's
schema and covering every parameter; paths that would leave the root are refused with PX4's NAKs; 1 000 random
requests leave the vehicle flying and the files intact."""

from __future__ import annotations

import errno
import json
import math
import random
import threading
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip(
    "mavsdk", minversion="4", reason="MAVSDK-Python 4 (the native binding) is a test extra: pip install '.[test]'"
)

from mavsdk import Mavsdk  # noqa: E402
from mavsdk.plugins.component_metadata import ComponentMetadata, MetadataType  # noqa: E402
from mavsdk.plugins.ftp import FilesystemEntry, Ftp, FtpResult  # noqa: E402

from autopilot.mavlink.component_metadata import MAVLINK_MSG_ID_COMPONENT_METADATA  # noqa: E402
from autopilot.mavlink.ftp_protocol import Nak, Opcode, Payload  # noqa: E402
from tests.sitl.ground_station import GroundStation  # noqa: E402
from tests.sitl.mavsdk_client import connect_autopilot  # noqa: E402
from tiltrotor_sitl import Vehicle  # noqa: E402
from transport.mavlink import mavlink  # noqa: E402

jsonschema = pytest.importorskip("jsonschema", reason="jsonschema is a test extra: pip install '.[test]'")
HOLD = (4 << 16) | (3 << 24)
SCHEMAS = Path(__file__).parents[1] / "data" / "component_metadata"


class FtpClient:
    """Raw FTP requests from a pymavlink ground station, one at a time, each answered by one reply."""

    def __init__(self, gs: GroundStation) -> None:
        self.gs = gs
        self.seq = 0

    def send(self, payload: Payload) -> None:
        self.gs.conn.mav.file_transfer_protocol_send(0, self.gs.vehicle, 1, payload.encode())

    def request(self, opcode: int, data: bytes = b"", *, offset: int = 0, session: int = 0, size: int | None = None
                ) -> Payload:  # fmt: skip
        self.seq = (self.seq + 2) & 0xFFFF
        with self.gs.recording("FILE_TRANSFER_PROTOCOL") as replies:
            self.send(Payload(self.seq, session, opcode, len(data) if size is None else size, 0, 0, offset, data))
            self.gs.wait(lambda: any(self._answers(r) for r in replies), f"the reply to FTP opcode {opcode}", 20.0)
            return next(Payload.decode(bytes(r.payload)) for r in replies if self._answers(r))

    def _answers(self, message: Any) -> bool:
        return Payload.decode(bytes(message.payload)).seq == (self.seq + 1) & 0xFFFF


def crc32part(data: bytes) -> int:
    """The CRC32 of MAVLink FTP (PX4, NuttX's crc32part): reflected polynomial 0xEDB88320, from 0, no inversions."""
    table = []
    for byte in range(256):
        value = byte
        for _ in range(8):
            value = (value >> 1) ^ 0xEDB88320 if value & 1 else value >> 1
        table.append(value)
    crc = 0
    for byte in data:
        crc = table[(crc ^ byte) & 0xFF] ^ (crc >> 8)
    return crc


def parameter_metadata(system: Any) -> dict:
    """The autopilot's parameter metadata as MAVSDK's component_metadata plugin fetches it."""
    plugin = ComponentMetadata(system)
    done = threading.Event()
    handle = plugin.subscribe_metadata_available(
        lambda update, user_data: done.set() if update.type == MetadataType.ALL_COMPLETED else None
    )
    plugin.request_autopilot_component()
    assert done.wait(60.0), "MAVSDK's component metadata did not complete"
    plugin.unsubscribe_metadata_available(handle)
    return json.loads(plugin.get_metadata(1, MetadataType.PARAMETER).json_metadata)


def mavsdk_ftp(api_port: int) -> tuple[Mavsdk, Any, Ftp]:
    drone, system = connect_autopilot(f"udpin://127.0.0.1:{api_port}")
    return drone, system, Ftp(system)


DIRECTORY = FilesystemEntry.EntryType.DIRECTORY


def entries(ftp: Ftp, path: str) -> set[tuple[str, Any]]:
    return {(entry.name, entry.entry_type) for entry in ftp.list_directory(path).entries}


def short_flight_log(gs: GroundStation, vehicle: Vehicle) -> Path:
    """Arm and disarm on the ground: SDLOG_MODE 0 writes a log between the two."""
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED
    gs.wait_sim(1.0)
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == mavlink.MAV_RESULT_ACCEPTED
    gs.wait_sim(0.5)
    logs = vehicle.logs()
    assert len(logs) == 1
    return logs[0]


def test_mavsdk_lists_the_root_and_downloads_a_log_whose_crc_matches_and_escapes_are_refused(tmp_path):
    vehicle = Vehicle(controller="pid", speed=4.0, truth=False, folder=tmp_path / "vehicles").start()
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.txt").write_text("not for ground stations")
    (vehicle.folder / "escape").symlink_to(outside)
    gs = GroundStation(vehicle.gcs_port, vehicle.sysid)
    drone = None
    try:
        gs.connect()
        log = short_flight_log(gs, vehicle)
        remote = f"/log/{log.parent.name}/{log.name}"
        drone, system, ftp = mavsdk_ftp(vehicle.api_port)
        assert {("log", DIRECTORY), ("etc", DIRECTORY)} <= entries(ftp, "/")
        assert entries(ftp, "/log") == {(log.parent.name, DIRECTORY)}
        day = {(entry.name, entry.size_bytes) for entry in ftp.list_directory(f"/log/{log.parent.name}").entries}
        assert day == {(log.name, log.stat().st_size)}
        assert ftp.are_files_identical(str(log), remote)  # the vehicle's CRC32 against MAVSDK's own
        done, outcome = threading.Event(), []

        def progress(result: FtpResult, data: Any, user_data: Any) -> None:
            if result != FtpResult.NEXT:
                outcome.append(result)
                done.set()

        ftp.download_async(remote, str(tmp_path), True, progress)
        assert done.wait(60.0) and outcome == [FtpResult.SUCCESS]
        assert (tmp_path / log.name).read_bytes() == log.read_bytes()

        metadata = parameter_metadata(system)  # as MAVSDK fetches it: COMPONENT_METADATA, then MAVLink FTP
        jsonschema.validate(metadata, json.loads((SCHEMAS / "parameter.schema.json").read_text()))
        with gs.recording("PARAM_VALUE") as values:
            gs.conn.mav.param_request_list_send(gs.vehicle, 1)
            gs.wait(lambda: values and len({v.param_id for v in values}) == values[0].param_count, "the parameters")
        assert {entry["name"] for entry in metadata["parameters"]} == {value.param_id for value in values}
        with gs.recording("COMPONENT_METADATA") as announced:
            ack = gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, MAVLINK_MSG_ID_COMPONENT_METADATA)
            assert ack.result == mavlink.MAV_RESULT_ACCEPTED
            gs.wait(lambda: bool(announced), "COMPONENT_METADATA")
        assert announced[0].uri.rstrip(b"\0") == b"mftp://etc/extras/component_general.json"

        client = FtpClient(gs)
        crc = client.request(Opcode.CALC_FILE_CRC32, remote.encode())
        assert crc.opcode == Opcode.ACK and int.from_bytes(crc.data[:4], "little") == crc32part(log.read_bytes())
        refusals = {
            b"../params.json": (Nak.FAIL_ERRNO, errno.EACCES),
            b"/log/../../outside/secret.txt": (Nak.FAIL_ERRNO, errno.EACCES),
            b"/escape/secret.txt": (Nak.FAIL_ERRNO, errno.EACCES),  # a link out of the root
            str(outside / "secret.txt").encode(): (Nak.FILE_NOT_FOUND, None),  # a host path: inside the root, no such
            b"/etc/passwd": (Nak.FILE_NOT_FOUND, None),
            b"@PARAM/param.pck": (Nak.FILE_NOT_FOUND, None),  # not served: the parameter protocol is
        }
        for path, (code, error) in refusals.items():
            answer = client.request(Opcode.OPEN_FILE_RO, path)
            assert (answer.opcode, answer.req_opcode, answer.data[0]) == (Opcode.NAK, Opcode.OPEN_FILE_RO, code), path
            if error is not None:
                assert answer.size == 2 and answer.data[1] == error, path
        protected = client.request(Opcode.CREATE_FILE, b"/etc/extras/parameters.json")
        assert (protected.opcode, protected.data[0]) == (Opcode.NAK, Nak.FILE_PROTECTED)
        assert client.request(Opcode.REMOVE_FILE, b"/escape/secret.txt").data[0] == Nak.FAIL_ERRNO
        assert (outside / "secret.txt").read_text() == "not for ground stations"
    finally:
        if drone is not None:
            drone.destroy()
        gs.close()
        vehicle.stop()


def random_request(rng: random.Random, reads: list[bytes], writes: list[bytes]) -> Payload:
    """A request a confused or hostile client might send: any opcode, session, size, offset, path or junk."""
    opcode = rng.choice([*range(0, 18), 128, 129, rng.randrange(256)])
    if rng.random() < 0.15:
        data = rng.randbytes(rng.randrange(240))
    elif opcode == Opcode.RENAME:
        data = rng.choice(writes) + b"\0" + rng.choice(writes)
    elif opcode in (Opcode.OPEN_FILE_RO, Opcode.LIST_DIRECTORY, Opcode.CALC_FILE_CRC32, Opcode.READ_FILE,
                    Opcode.BURST_READ_FILE):  # fmt: skip
        data = rng.choice(reads + writes)
    else:
        data = rng.choice(writes) if rng.random() < 0.9 else rng.randbytes(40)
    size = len(data) if rng.random() < 0.7 else rng.randrange(256)
    offset = rng.choice([0, rng.randrange(1000), rng.randrange(1 << 32), (1 << 32) - 1])
    session = 0 if rng.random() < 0.8 else rng.randrange(256)
    return Payload(rng.randrange(1 << 16), session, opcode, size, rng.randrange(256), rng.randrange(2), offset, data)


def test_a_thousand_random_ftp_requests_leave_the_vehicle_flying_and_the_files_intact(tmp_path):
    vehicle = Vehicle(controller="mpc", speed=4.0, truth=False, folder=tmp_path / "vehicles",
                      params={"MIS_TAKEOFF_ALT": 10.0}).start()  # fmt: skip
    outside = tmp_path / "outside"
    outside.mkdir()
    sentinel = outside / "sentinel.txt"
    sentinel.write_text("outside the root")
    gs = GroundStation(vehicle.gcs_port, vehicle.sysid)
    try:
        gs.connect()
        log = short_flight_log(gs, vehicle)
        kept = {path: path.read_bytes() for path in [log, vehicle.params_path, *vehicle.folder.glob("etc/extras/*")]}
        assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == mavlink.MAV_RESULT_ACCEPTED
        assert gs.command(mavlink.MAV_CMD_NAV_TAKEOFF, *([math.nan] * 7)).result == mavlink.MAV_RESULT_ACCEPTED
        gs.wait(lambda: gs.altitude > 9.5, "the takeoff to 10 m", 120.0)
        gs.wait(lambda: gs.latest["HEARTBEAT"].custom_mode == HOLD, "Hold", 60.0)
        reads = [f"/log/{log.parent.name}/{log.name}".encode(), b"/", b"/log", b"etc/extras/parameters.json"]
        writes = [b"/etc/extras/parameters.json", b"/etc/extras", b"/params.json", b"/" + vehicle.params_path.name.encode(),
                  b"../outside/sentinel.txt", str(sentinel).encode(), b"/log/../../outside", b"scratch",
                  b"scratch/file.bin", b"/fs/microsd/scratch/other", b"", b"/", b"/log"]  # fmt: skip
        rng = random.Random(36)
        client = FtpClient(gs)
        before = sorted(path.name for path in tmp_path.iterdir())
        with gs.recording("FILE_TRANSFER_PROTOCOL") as replies:
            for batch in range(50):
                for _ in range(20):
                    client.send(random_request(rng, reads, writes))
                gs.pump(0.05)
                assert abs(gs.altitude - 10.0) < 1.0, f"altitude {gs.altitude:.2f} m after batch {batch}"
        assert len(replies) > 500  # answered (a burst read answers with many, bad targets with none)
        gs.wait_sim(2.0)
        assert vehicle.running() and gs.armed and abs(gs.altitude - 10.0) < 1.0
        assert gs.latest["HEARTBEAT"].custom_mode == HOLD
        assert gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION).result == 0
        # A last request is still served as ever.
        assert client.request(Opcode.RESET_SESSIONS).opcode == Opcode.ACK
        listing = client.request(Opcode.LIST_DIRECTORY, f"/log/{log.parent.name}".encode())
        assert listing.opcode == Opcode.ACK and log.name.encode() in listing.data
    finally:
        gs.close()
        vehicle.stop()
    for path, content in kept.items():
        assert path.read_bytes() == content, f"{path} changed"
    assert sentinel.read_text() == "outside the root" and sorted(p.name for p in outside.iterdir()) == ["sentinel.txt"]
    assert sorted(path.name for path in tmp_path.iterdir()) == before
