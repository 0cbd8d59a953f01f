"""MAVLink 2 signing on the ground links (issue 12 item 3), through the real processes with pymavlink clients."""

from __future__ import annotations

import json
import signal
import time

from tests.sitl.ground_station import GroundStation, said
from tests.sitl.mavlink_sitl import start_sitl
from transport.link_signing import timestamp_at
from transport.mavlink import MAV_RESULT_ACCEPTED, MAV_RESULT_DENIED, mavlink

KEY = bytes(range(1, 33))


def setup_signing(gs: GroundStation, key: bytes, timestamp: int) -> None:
    gs.conn.mav.setup_signing_send(gs.vehicle, 1, list(key), timestamp)


def saved_key(params_path) -> str | None:
    """The signing key in the autopilot's parameter file (hex), None before the file is written."""
    if not params_path.exists():
        return None
    return json.loads(params_path.read_text()).get("signing", {}).get("key")


def test_a_keyed_client_flies_an_unkeyed_one_is_refused_and_the_key_survives_a_restart(tmp_path):
    params_path = tmp_path / "params.json"
    sitl = start_sitl(params_path, speed=4.0, controller="pid", autopilot_args=("--quiet",))
    keyed = sitl.gs
    unkeyed = GroundStation(sitl.ports["api_remote"], sitl.vehicle.sysid)  # the API link: same vehicle, no key
    try:
        keyed.connect()
        setup_signing(keyed, bytes(32), 5)  # malformed: an all-zero key with a timestamp
        said(keyed, "SETUP_SIGNING refused: all-zero key")
        setup_signing(keyed, KEY, timestamp_at(time.time()))  # no key yet: taken unsigned
        said(keyed, "signing: key set")
        keyed.conn.setup_signing(KEY, sign_outgoing=True)
        # The parameter file is written on the autopilot's writer thread, after the answer (autopilot/storage/kept_file.py).
        keyed.wait(lambda: saved_key(params_path) == KEY.hex(), "the key in the parameter file")

        unkeyed.connect()  # telemetry reaches unsigned clients
        assert keyed.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == MAV_RESULT_ACCEPTED
        assert keyed.command(mavlink.MAV_CMD_NAV_TAKEOFF, *([float("nan")] * 7)).result == MAV_RESULT_ACCEPTED
        # Every command of the unkeyed client is refused while the keyed one's takeoff goes on.
        assert unkeyed.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == MAV_RESULT_DENIED
        assert unkeyed.command(mavlink.MAV_CMD_NAV_LAND).result == MAV_RESULT_DENIED
        assert unkeyed.set_mode((4 << 16) | (6 << 24)).result == MAV_RESULT_DENIED
        unkeyed.conn.mav.command_int_send(
            unkeyed.vehicle, 1, 0, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0, 0
        )
        unkeyed.conn.mav.param_set_send(unkeyed.vehicle, 1, b"MIS_TAKEOFF_ALT", 50.0, mavlink.MAV_PARAM_TYPE_REAL32)
        unkeyed.conn.mav.set_mode_send(1, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 6 << 16)
        unkeyed.velocity_setpoint(0, 0, 5)
        unkeyed.conn.mav.mission_clear_all_send(1, 1)
        setup_signing(unkeyed, bytes(32), 0)  # an unsigned attempt to remove the key
        unkeyed.wait(lambda: sum(a.result == MAV_RESULT_DENIED for a in unkeyed.acks) >= 4, "the COMMAND_INT refusal")
        keyed.wait(lambda: keyed.altitude > 2.0, "the keyed client's takeoff", timeout_s=60)
        assert keyed.armed
        unkeyed.conn.mav.param_request_read_send(unkeyed.vehicle, 1, b"MIS_TAKEOFF_ALT", -1)  # reading is allowed
        unkeyed.wait(lambda: any(p.param_id == "MIS_TAKEOFF_ALT" for p in unkeyed.param_values), "a read")
        assert unkeyed.param_values[-1].param_value == 2.5
        assert keyed.command(mavlink.MAV_CMD_NAV_LAND).result == MAV_RESULT_ACCEPTED

        # The key survives a restart: the new autopilot still refuses the unkeyed client and obeys the keyed one.
        sitl.autopilot.send_signal(signal.SIGTERM)
        sitl.autopilot.wait(timeout=30)
        summary = sitl.vehicle.summary("vtol-autopilot")
        links = summary["links"]
        assert links["signing"] and links["signing_required"] and links["unsigned_refused"] >= 9
        assert links["api"]["ignored"]["unsigned:PARAM_SET"] == 1
        sitl.restart_autopilot()
        keyed.latest.pop("HEARTBEAT", None)
        keyed.wait(lambda: "HEARTBEAT" in keyed.latest, "the restarted autopilot", timeout_s=60)
        assert keyed.latest["HEARTBEAT"].get_signed()  # outgoing messages are signed with the stored key
        interval = (mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_VFR_HUD, 200_000)
        assert keyed.command(*interval).result == MAV_RESULT_ACCEPTED
        unkeyed.heartbeat()
        assert unkeyed.command(*interval).result == MAV_RESULT_DENIED
    finally:
        unkeyed.close()
        sitl.kill()
