"""The mission protocol (issue 11 item 1, docs/missions.md): uploads and downloads of missions, fences and
rally points through the real processes, clear, current item, persistence across a restart, bad input refused with
PX4's MISSION_ACK results and the stored lists left intact, an abandoned upload."""

from __future__ import annotations

import json
import math
import time
from typing import Any

import pytest

from tests.sitl.ground_station import GroundStation, MissionClient
from tests.sitl.mavlink_sitl import Sitl, start_sitl
from tests.unit.test_mavlink_missions import FENCE, RALLY, REL, SURVEY, TYPES, item
from transport.mavlink import mavlink as M

LAT, LON = 473977420, 85455940


def test_the_autopilot_refuses_a_broken_mission_file_with_one_line_and_exit_2(tmp_path):
    (tmp_path / "missions-0.json").write_text('{"format": "tiltrotor-sitl missions", "version": 1, "mission": 5}')
    sitl = start_sitl(tmp_path / "params.json", ground_station=False, wait_ready=False)
    try:
        assert sitl.autopilot.wait(timeout=60) == 2
        lines = sitl.stderr().strip().splitlines()
        assert len(lines) == 1 and "mission file" in lines[0], lines
    finally:
        sitl.kill()


# ---- through the real processes -----------------------------------------------------------------------------------------
def rows_of(items: list) -> list[tuple]:
    return [(i.frame, i.command, i.param1, i.param2, i.param3, i.param4, i.x, i.y, i.z) for i in items]


def same(a: list[tuple], b: list[tuple]) -> bool:
    """Equal item lists (NaN parameters equal too)."""
    return repr([item(r) for r in a]) == repr([item(r) for r in b])


def connected_vehicle(folder):
    """A vehicle on the ground (real time x4), its files in `folder`, with its ground station and mission client."""
    sitl = start_sitl(folder / "params.json", speed=4.0)
    try:
        sitl.gs.connect()
        yield sitl, MissionClient(sitl.gs)
    finally:
        sitl.kill()


@pytest.fixture(scope="module")
def vehicle(tmp_path_factory):
    """One vehicle for the protocol tests: each uploads what it needs and asks nothing of what ran before."""
    yield from connected_vehicle(tmp_path_factory.mktemp("missions"))


@pytest.fixture
def own_vehicle(tmp_path):
    """A vehicle of its own, for a test that restarts its autopilot."""
    yield from connected_vehicle(tmp_path)


def test_round_trip_of_each_type_clear_and_current(vehicle):
    sitl, client = vehicle
    for kind, rows in TYPES.items():
        assert client.upload(kind, rows) == M.MAV_MISSION_ACCEPTED
    for kind, rows in TYPES.items():
        assert same(rows_of(client.download(kind)), rows), kind
    current = client.next("MISSION_CURRENT")
    assert current.total == len(SURVEY) and current.mission_state == M.MISSION_STATE_NOT_STARTED

    client.mav.mission_set_current_send(client.gs.vehicle, 1, 4)
    deadline = time.monotonic() + 10
    while client.next("MISSION_CURRENT").seq != 4:
        assert time.monotonic() < deadline
    client.mav.mission_set_current_send(client.gs.vehicle, 1, 99)
    while not any("99" in t for t in client.statustexts):
        client.next("STATUSTEXT")
    assert [i.current for i in client.download(M.MAV_MISSION_TYPE_MISSION)] == [0, 0, 0, 0, 1, 0, 0, 0, 0]

    client.mav.mission_clear_all_send(client.gs.vehicle, 1, M.MAV_MISSION_TYPE_RALLY)
    assert client.next("MISSION_ACK").type == M.MAV_MISSION_ACCEPTED
    assert client.download(M.MAV_MISSION_TYPE_RALLY) == []
    assert len(client.download(M.MAV_MISSION_TYPE_FENCE)) == len(FENCE)
    assert client.upload(M.MAV_MISSION_TYPE_RALLY, RALLY) == M.MAV_MISSION_ACCEPTED


def test_legacy_mission_item_is_accepted_and_served(vehicle):
    sitl, client = vehicle
    rows = [(M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_CMD_NAV_RALLY_POINT, 0, 0, 0, 0, 47.3977, 8.5456, 15.0)]
    client.mav.mission_count_send(client.gs.vehicle, 1, 1, M.MAV_MISSION_TYPE_RALLY)
    assert client.next("MISSION_REQUEST_INT").seq == 0
    client.mav.mission_item_send(client.gs.vehicle, 1, 0, *rows[0][:2], 0, 1, *rows[0][2:], M.MAV_MISSION_TYPE_RALLY)
    assert client.next("MISSION_ACK").type == M.MAV_MISSION_ACCEPTED
    stored = client.download(M.MAV_MISSION_TYPE_RALLY)
    # float32 degrees (why MISSION_ITEM is deprecated): about 0.5 m of resolution
    assert abs(stored[0].x - 473977000) < 50 and abs(stored[0].y - 85456000) < 50 and stored[0].z == 15.0
    assert client.upload(M.MAV_MISSION_TYPE_RALLY, RALLY) == M.MAV_MISSION_ACCEPTED


def bad_upload(client, rows: list[tuple], bad_seq: int, bad) -> int:
    """Upload `rows`, answering request `bad_seq` with bad(client); the ACK's result."""
    kind = M.MAV_MISSION_TYPE_MISSION
    client.mav.mission_count_send(client.gs.vehicle, 1, len(rows), kind)
    for seq, row in enumerate(rows):
        request = client.next("MISSION_REQUEST_INT", "MISSION_ACK")
        if request.get_type() == "MISSION_ACK":
            return request.type
        if seq == bad_seq:
            bad(client, seq, row)
            return client.next("MISSION_ACK").type
        client.send_item(seq, row, kind)
    return client.next("MISSION_ACK").type


BAD_TRANSFERS = {
    "unknown command": (lambda c, s, r: c.send_item(s, (REL, 31337, *r[2:]), 0), M.MAV_MISSION_UNSUPPORTED),
    "NaN latitude (legacy item)": (lambda c, s, r: c.mav.mission_item_send(
        1, 1, s, M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 0, 0, 0, math.nan, 8.5, 20.0, 0),
        M.MAV_MISSION_INVALID_PARAM5_X),
    "longitude out of range": (lambda c, s, r: c.send_item(s, (*r[:7], 1_900_000_000, r[8]), 0),
                               M.MAV_MISSION_INVALID_PARAM6_Y),
    "wrong frame": (lambda c, s, r: c.send_item(s, (M.MAV_FRAME_LOCAL_NED, *r[1:]), 0),
                    M.MAV_MISSION_UNSUPPORTED_FRAME),
    "item beyond the requested one": (lambda c, s, r: c.send_item(s + 2, r, 0), M.MAV_MISSION_INVALID_SEQUENCE),
    "item of another mission type": (lambda c, s, r: c.send_item(s, r, M.MAV_MISSION_TYPE_FENCE), M.MAV_MISSION_ERROR),
}  # fmt: skip


@pytest.mark.parametrize("case", list(BAD_TRANSFERS))
def test_bad_input_is_refused_with_px4s_ack_and_the_mission_stays(vehicle, case):
    sitl, client = vehicle
    bad, result = BAD_TRANSFERS[case]
    assert client.upload(M.MAV_MISSION_TYPE_MISSION, SURVEY[:3]) == M.MAV_MISSION_ACCEPTED  # whatever ran before
    before = rows_of(client.download(M.MAV_MISSION_TYPE_MISSION))
    assert same(before, SURVEY[:3])
    assert bad_upload(client, SURVEY[:4], 1, bad) == result
    assert same(rows_of(client.download(M.MAV_MISSION_TYPE_MISSION)), before)


def test_counts_other_clients_and_other_systems(vehicle):
    sitl, client = vehicle
    before = rows_of(client.download(M.MAV_MISSION_TYPE_MISSION))
    client.mav.mission_count_send(client.gs.vehicle, 1, 501, M.MAV_MISSION_TYPE_MISSION)
    assert client.next("MISSION_ACK").type == M.MAV_MISSION_NO_SPACE
    client.mav.mission_count_send(client.gs.vehicle, 1, 9, M.MAV_MISSION_TYPE_RALLY)
    assert client.next("MISSION_ACK").type == M.MAV_MISSION_NO_SPACE
    # For another system: no answer at all.
    client.mav.mission_count_send(7, 1, 1, M.MAV_MISSION_TYPE_MISSION)
    client.mav.mission_clear_all_send(7, 1, M.MAV_MISSION_TYPE_MISSION)
    with pytest.raises(AssertionError):
        client.next("MISSION_ACK", "MISSION_REQUEST_INT", timeout_s=1.5)
    # A second client (another system id) while an upload runs: DENIED; the first goes on.
    client.mav.mission_count_send(client.gs.vehicle, 1, 1, M.MAV_MISSION_TYPE_MISSION)
    assert client.next("MISSION_REQUEST_INT").seq == 0
    client.mav.srcSystem = 254
    try:
        client.mav.mission_count_send(client.gs.vehicle, 1, 2, M.MAV_MISSION_TYPE_MISSION)
        denied = client.next("MISSION_ACK")
        assert denied.type == M.MAV_MISSION_DENIED and denied.target_system == 254
    finally:
        client.mav.srcSystem = 255
    client.mav.mission_ack_send(client.gs.vehicle, 1, M.MAV_MISSION_OPERATION_CANCELLED, M.MAV_MISSION_TYPE_MISSION)
    assert same(rows_of(client.download(M.MAV_MISSION_TYPE_MISSION)), before)


def test_an_abandoned_upload_is_retried_then_cancelled_and_the_mission_stays(vehicle):
    sitl, client = vehicle
    before = rows_of(client.download(M.MAV_MISSION_TYPE_MISSION))
    client.mav.mission_count_send(client.gs.vehicle, 1, 3, M.MAV_MISSION_TYPE_MISSION)
    assert client.next("MISSION_REQUEST_INT").seq == 0
    client.send_item(0, SURVEY[0], 0)
    assert client.next("MISSION_REQUEST_INT").seq == 1
    # The mission protocol's retries (every 0.25 s) and time-out (5 s) are in wall time, as PX4's: the partner is a
    # program that runs in wall time, whatever the simulation's speed (autopilot/mavlink/mission_transfer.py), so
    # they are measured here in wall time.
    started = time.monotonic()
    retries = 0
    while True:  # we stop answering: the request is repeated, then the upload is cancelled
        message = client.next("MISSION_REQUEST_INT", "MISSION_ACK", timeout_s=10)
        if message.get_type() == "MISSION_ACK":
            break
        assert message.seq == 1
        retries += 1
    cancelled_after = time.monotonic() - started
    print(f"{retries} retries, cancelled after {cancelled_after:.2f} s")
    assert message.type == M.MAV_MISSION_OPERATION_CANCELLED
    # 5 s of silence at a retry each 0.25 s: 19 retries (at most 20); at least 10 on a busy machine
    assert 10 <= retries <= 20 and 4.5 < cancelled_after < 8.0
    assert same(rows_of(client.download(M.MAV_MISSION_TYPE_MISSION)), before)


def count_asked_while_starting(sitl: Sitl) -> Any:
    """Restart the autopilot, asking for the mission's count (MISSION_REQUEST_LIST every 50 ms, on the API link
    from a socket of its own) from the moment it is started: the first MISSION_COUNT, which must come before the
    new autopilot's first HEARTBEAT (the request was answered before its first status went out)."""
    probe = GroundStation(sitl.ports["api"], sitl.vehicle.sysid, speaks_first=True)
    try:
        sitl.restart_autopilot()
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            probe.conn.mav.mission_request_list_send(probe.vehicle, 1, M.MAV_MISSION_TYPE_MISSION)
            first = probe.conn.recv_match(type=["MISSION_COUNT", "HEARTBEAT"], blocking=True, timeout=0.05)
            if first is not None:
                # after every request sent: it ends the download they started, which would refuse the GCS client's
                probe.conn.mav.mission_ack_send(probe.vehicle, 1, M.MAV_MISSION_ACCEPTED, M.MAV_MISSION_TYPE_MISSION)
                assert first.get_type() == "MISSION_COUNT", "no request reached the autopilot before its first status"
                return first
        raise AssertionError("no answer from the restarted autopilot within 60 s")
    finally:
        probe.close()


def test_missions_survive_an_autopilot_restart(own_vehicle):
    sitl, client = own_vehicle
    for kind, rows in TYPES.items():
        assert client.upload(kind, rows) == M.MAV_MISSION_ACCEPTED
    client.mav.mission_set_current_send(client.gs.vehicle, 1, 3)
    while client.next("MISSION_CURRENT").seq != 3:
        pass
    stored = {kind: rows_of(client.download(kind)) for kind in TYPES}
    assert all(same(stored[kind], rows) for kind, rows in TYPES.items())
    sitl.autopilot.terminate()
    sitl.autopilot.wait(timeout=30)
    assert json.loads((sitl.params_path.parent / "missions-0.json").read_text())["current"] == 3
    # asked while it starts (as a ground station that keeps asking does), it serves the stored mission at once
    assert count_asked_while_starting(sitl).count == len(SURVEY)
    client.gs.heartbeat()
    for kind in TYPES:
        assert same(rows_of(client.download(kind)), stored[kind]), kind
    current = client.next("MISSION_CURRENT")
    assert current.seq == 3 and current.total == len(SURVEY)
