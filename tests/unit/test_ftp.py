"""MAVLink FTP without sockets: the payload, the paths (nothing outside the root), and the service's answers to
each opcode, as PX4's mavlink_ftp gives them, for requests parsed from real frames."""

from __future__ import annotations

import errno
import zlib

import pytest

from autopilot.mavlink.ftp import BURST_BYTES, FtpService
from autopilot.mavlink.ftp_protocol import MAX_DATA, FileRoot, Nak, Opcode, PathRefused, Payload, crc32_update
from transport.mavlink import Link

VEHICLE, CLIENT = (1, 1), (255, 190)


class QueueLink:
    def __init__(self) -> None:
        self.mav = Link(*VEHICLE).mav
        self.sent: list = []

    def queue(self, message) -> None:
        self.sent.append(message)


class Client:
    """Requests as a ground station frames them, answers as the vehicle queued them."""

    def __init__(self, service: FtpService) -> None:
        self.service, self.link, self.seq = service, QueueLink(), 0
        self._encoder, self._decoder = Link(*CLIENT), Link(*VEHICLE)

    def send(self, opcode: int, data: bytes = b"", *, offset: int = 0, session: int = 0, size: int | None = None,
             seq: int | None = None, target: int = 1) -> list[Payload]:  # fmt: skip
        self.seq = self.seq + 2 if seq is None else seq
        payload = Payload(self.seq, session, opcode, len(data) if size is None else size, 0, 0, offset, data)
        frame = self._encoder.pack(self._encoder.mav.file_transfer_protocol_encode(0, target, 1, payload.encode()))
        (message,) = self._decoder.parse(frame)
        self.link.sent.clear()
        self.service.on_file_transfer_protocol(self.link, message)
        for reply in self.link.sent:
            assert (reply.target_system, reply.target_component) == CLIENT
        return [Payload.decode(bytes(reply.payload)) for reply in self.link.sent]

    def ask(self, opcode: int, data: bytes = b"", **fields) -> Payload:
        (answer,) = self.send(opcode, data, **fields)
        assert answer.seq == self.seq + 1 and answer.req_opcode == opcode
        return answer


def nak(answer: Payload) -> tuple[int, ...]:
    assert answer.opcode == Opcode.NAK
    return tuple(answer.data[: answer.size])


@pytest.fixture
def vehicle_root(tmp_path):
    root = tmp_path / "root"
    (root / "log" / "2026-01-01").mkdir(parents=True)
    (root / "log" / "2026-01-01" / "12_00_00.ulg").write_bytes(bytes(range(256)) * 40)
    (root / "etc" / "extras").mkdir(parents=True)
    (root / "etc" / "extras" / "parameters.json").write_text("{}")
    (root / "params.json").write_text("{}")
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / "secret").write_text("secret")
    (root / "escape").symlink_to(tmp_path / "outside")
    protected = frozenset({root / "params.json", root / "etc" / "extras"})
    return FileRoot(root, root / "log", protected)


@pytest.fixture
def client(vehicle_root):
    return Client(FtpService(vehicle_root, system_id=1, wall_clock=lambda: 0.0))


def test_the_payload_round_trips():
    payload = Payload(65535, 3, Opcode.READ_FILE, 5, 0, 1, 1 << 31, b"hello")
    assert len(payload.encode()) == 251 and Payload.decode(payload.encode()).text == b"hello"
    assert Payload.decode(b"\x01").seq == 1  # a short payload is padded, not refused


def test_paths_stay_in_the_root(vehicle_root):
    root = vehicle_root.root
    assert vehicle_root.resolve(b"/log/2026-01-01") == root / "log" / "2026-01-01"
    assert vehicle_root.resolve(b"//fs/microsd/./params.json") == root / "params.json"  # PX4's SD card path
    assert vehicle_root.resolve(b"/etc/passwd") == root / "etc" / "passwd"  # a host path names a file in the root
    assert vehicle_root.resolve(b"") == root
    for path, error in ((b"../outside", errno.EACCES), (b"log/../../x", errno.EACCES), (b"/escape/secret", errno.EACCES),
                        (b"/escape", errno.EACCES), (b"\xff\xfe", errno.EINVAL)):  # fmt: skip
        with pytest.raises(PathRefused) as refused:
            vehicle_root.resolve(path)
        assert tuple(refused.value.nak) == (Nak.FAIL_ERRNO, error), path
    with pytest.raises(PathRefused):
        vehicle_root.writable(root / "etc" / "extras" / "parameters.json")
    with pytest.raises(PathRefused):
        vehicle_root.writable(root / "params.json")
    vehicle_root.writable(root / "log" / "new.bin")


def test_the_log_folder_may_be_elsewhere(tmp_path):
    files = FileRoot(tmp_path / "root", tmp_path / "logs")
    assert files.resolve(b"/log/2026-01-01/a.ulg") == tmp_path / "logs" / "2026-01-01" / "a.ulg"


def test_list_read_burst_crc_as_px4(client, vehicle_root):
    log = vehicle_root.root / "log" / "2026-01-01" / "12_00_00.ulg"
    content = log.read_bytes()
    listing = client.ask(Opcode.LIST_DIRECTORY, b"/")
    assert listing.data[: listing.size].split(b"\0")[:-1] == [
        b"S",
        b"Detc",
        b"Dlog",
        b"Fparams.json\t2",
    ]  # escape: a link
    assert nak(client.ask(Opcode.LIST_DIRECTORY, b"/", offset=10)) == (Nak.EOF,)
    assert nak(client.ask(Opcode.LIST_DIRECTORY, b"/nothing")) == (Nak.FILE_NOT_FOUND,)
    opened = client.ask(Opcode.OPEN_FILE_RO, b"/log/2026-01-01/12_00_00.ulg")
    assert opened.opcode == Opcode.ACK and int.from_bytes(opened.data[:4], "little") == len(content)
    assert nak(client.ask(Opcode.OPEN_FILE_RO, b"/params.json")) == (Nak.NO_SESSIONS_AVAILABLE,)
    read = client.ask(Opcode.READ_FILE, offset=1000, size=MAX_DATA)
    assert read.data[: read.size] == content[1000 : 1000 + MAX_DATA]
    assert nak(client.ask(Opcode.READ_FILE, offset=len(content), size=10)) == (Nak.EOF,)
    assert nak(client.ask(Opcode.READ_FILE, session=1)) == (Nak.INVALID_SESSION,)
    assert client.send(Opcode.BURST_READ_FILE, offset=0) == []  # the burst's packets come from send()
    packets = []
    while client.service.burst is not None:
        client.link.sent.clear()
        client.service.send()
        packets += [Payload.decode(bytes(m.payload)) for m in client.link.sent]
    assert b"".join(p.data[: p.size] for p in packets) == content
    assert packets[-1].burst_complete == 1 and [p.seq for p in packets] == list(
        range(packets[0].seq, packets[-1].seq + 1)
    )
    assert len(content) < BURST_BYTES
    assert client.ask(Opcode.TERMINATE_SESSION).opcode == Opcode.ACK
    assert nak(client.ask(Opcode.TERMINATE_SESSION)) == (Nak.INVALID_SESSION,)
    crc = client.ask(Opcode.CALC_FILE_CRC32, b"/log/2026-01-01/12_00_00.ulg")
    assert int.from_bytes(crc.data[:4], "little") == zlib.crc32(content, 0xFFFFFFFF) ^ 0xFFFFFFFF
    assert crc32_update(crc32_update(0, content[:7]), content[7:]) == crc32_update(0, content)


def test_writes_renames_removals_and_the_autopilots_files(client, vehicle_root):
    root = vehicle_root.root
    assert client.ask(Opcode.CREATE_DIRECTORY, b"/scratch").opcode == Opcode.ACK
    assert nak(client.ask(Opcode.CREATE_DIRECTORY, b"/scratch")) == (Nak.FILE_EXISTS,)
    assert client.ask(Opcode.CREATE_FILE, b"/scratch/a.bin").opcode == Opcode.ACK
    written = client.ask(Opcode.WRITE_FILE, b"abcdef", offset=2)
    assert int.from_bytes(written.data[:4], "little") == 6
    assert nak(client.ask(Opcode.WRITE_FILE, b"x", offset=1 << 31)) == (Nak.FAIL_ERRNO, errno.EFBIG)
    assert client.ask(Opcode.RESET_SESSIONS).opcode == Opcode.ACK
    assert (root / "scratch" / "a.bin").read_bytes() == b"\0\0abcdef"
    assert client.ask(Opcode.TRUNCATE_FILE, b"/scratch/a.bin", offset=4).opcode == Opcode.ACK
    assert client.ask(Opcode.RENAME, b"/scratch/a.bin\0/scratch/b.bin").opcode == Opcode.ACK
    assert (root / "scratch" / "b.bin").read_bytes() == b"\0\0ab"
    assert nak(client.ask(Opcode.RENAME, b"/scratch/b.bin")) == (Nak.FAIL_ERRNO, errno.EINVAL)
    assert nak(client.ask(Opcode.REMOVE_DIRECTORY, b"/scratch"))[0] == Nak.FAIL_ERRNO  # not empty
    assert client.ask(Opcode.REMOVE_FILE, b"/scratch/b.bin").opcode == Opcode.ACK
    assert client.ask(Opcode.REMOVE_DIRECTORY, b"/scratch").opcode == Opcode.ACK
    for opcode, path in ((Opcode.CREATE_FILE, b"/params.json"), (Opcode.REMOVE_FILE, b"/etc/extras/parameters.json"),
                         (Opcode.RENAME, b"/params.json\0/x"), (Opcode.RENAME, b"/log/x\0/params.json"),
                         (Opcode.TRUNCATE_FILE, b"/params.json"), (Opcode.REMOVE_DIRECTORY, b"/log"),
                         (Opcode.OPEN_FILE_WO, b"/etc/extras/new.json")):  # fmt: skip
        assert nak(client.ask(opcode, path)) == (Nak.FILE_PROTECTED,), (opcode, path)
    assert (root / "params.json").read_text() == "{}"
    assert nak(client.ask(Opcode.REMOVE_FILE, b"/escape/secret")) == (Nak.FAIL_ERRNO, errno.EACCES)
    assert (root.parent / "outside" / "secret").read_text() == "secret"
    assert nak(client.ask(Opcode.OPEN_FILE_RO, b"/log")) == (Nak.FAIL_ERRNO, errno.EISDIR)


def test_bad_requests_get_px4s_naks_and_a_lost_reply_is_sent_again(client):
    assert nak(client.ask(Opcode.LIST_DIRECTORY, b"/", size=240)) == (Nak.INVALID_DATA_SIZE,)
    assert nak(client.ask(77)) == (Nak.UNKNOWN_COMMAND,)
    assert nak(client.ask(Opcode.ACK)) == (Nak.UNKNOWN_COMMAND,)
    assert client.ask(Opcode.NONE).opcode == Opcode.ACK
    first = client.ask(Opcode.CREATE_DIRECTORY, b"/again", seq=100)
    again = client.send(Opcode.CREATE_DIRECTORY, b"/again", seq=100)  # the ACK was lost: the same ACK, not EEXIST
    assert again == [first] and first.opcode == Opcode.ACK
    assert client.send(Opcode.NONE, target=9) == []  # another vehicle's
    assert client.service.naks == 3
