"""The mission protocol as PX4 serves it (docs/missions.md), for the mission, geofence and rally lists.

Uploads and downloads run one at a time (mission_transfer.py holds their state); a complete, checked upload
becomes a `StoreMission` request to the flight stack, which keeps the lists (autopilot/storage/mission_store.py). The
stored lists are read from the VehicleStatus only (downloads, MISSION_CURRENT, MISSION_ITEM_REACHED), and before
the first one from the lists loaded at start (StatusView.missions). Bad input is refused with the MISSION_ACK
result PX4 sends (or, where PX4 sends none, the one the MAVLink spec names) and a STATUSTEXT, and leaves the
stored lists as they were. Messages for another system id are ignored.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from autopilot.mavlink import messages
from autopilot.mavlink.mission_transfer import (
    Download,
    Partner,
    Transfer,
    Upload,
    item_from_message,
    sequence_result,
)
from autopilot.mavlink.router import COMP_ID, GroundLink, Router
from autopilot.mavlink.statustext import Announcer
from autopilot.mavlink.view import StatusView
from autopilot.topics.mission_items import (
    FLOAT_FRAME_OF,
    MAX_ITEMS,
    MISSION,
    MISSION_TYPES,
    TYPE_NAMES,
    check_item,
    result_name,
    to_float_coordinates,
)
from autopilot.topics.missions import Missions
from autopilot.topics.requests import ClearMission, RequestHandler, SetMissionCurrent, StoreMission
from autopilot.topics.vehicle_status import VehicleStatus
from transport.mavlink import mavlink as M

MISSION_PLANNER_COMP = M.MAV_COMP_ID_MISSIONPLANNER  # PX4 also takes mission messages addressed to it


def for_us(system_id: int, message: Any) -> bool:
    return message.target_system == system_id and message.target_component in (0, COMP_ID, MISSION_PLANNER_COMP)


def partner_of(link: GroundLink, message: Any) -> Partner:
    return Partner(link, message.get_srcSystem(), message.get_srcComponent())


class MissionService:
    def __init__(self, flight_stack: RequestHandler, view: StatusView, router: Router, announcer: Announcer, *,
                 system_id: int, clock: Callable[[], float] = time.monotonic) -> None:  # fmt: skip
        self.flight_stack = flight_stack
        self.view = view
        self.router = router
        self.announcer = announcer
        self.system_id = system_id
        self.clock = clock
        self.transfer: Transfer | None = None
        self.refused = 0  # transfers ended by bad input or a time-out
        self._last_upload: tuple[Partner, int, int] | None = None  # partner, type, count: a repeated last item
        self._current_sent: tuple[int, int, int] | None = None
        self._reached_sent = 0

    @property
    def stored(self) -> Missions:
        return self.view.missions

    # ---- uploads ----------------------------------------------------------------------------------------------------
    def on_count(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message):
            return
        partner, now, kind = partner_of(link, message), self.clock(), message.mission_type
        busy = self._busy_for(partner)
        if busy is not None:
            self._ack(partner, kind, busy, "Mission upload refused: a transfer is running")
            return
        if isinstance(self.transfer, Upload) and self.transfer.next_seq == 0 and self.transfer.mission_type == kind:
            self.transfer.last_received = now  # our first request was lost: ask again
            self._request(self.transfer, now)
            return
        if kind not in MISSION_TYPES:
            self._ack(partner, kind, M.MAV_MISSION_UNSUPPORTED, f"Mission type {kind} not supported")
            return
        if message.count > MAX_ITEMS[kind]:
            self._ack(partner, kind, M.MAV_MISSION_NO_SPACE,
                      f"Too many {TYPE_NAMES[kind]} items: {message.count} > {MAX_ITEMS[kind]}")  # fmt: skip
            return
        self.transfer = None
        if message.count == 0:
            self.flight_stack.handle(ClearMission(kind))
            self._ack(partner, kind, M.MAV_MISSION_ACCEPTED)
            return
        upload = Upload(partner, kind, message.count, now, last_received=now)
        self.transfer = upload
        self._request(upload, now)

    def on_item_int(self, link: GroundLink, message: Any) -> None:
        self._on_item(link, message, int_mode=True)

    def on_item(self, link: GroundLink, message: Any) -> None:
        self._on_item(link, message, int_mode=False)

    def _on_item(self, link: GroundLink, message: Any, *, int_mode: bool) -> None:
        if not for_us(self.system_id, message):
            return
        partner, upload = partner_of(link, message), self.transfer
        if not isinstance(upload, Upload) or upload.partner != partner:
            self._item_outside_upload(partner, message)
            return
        upload.last_received = self.clock()
        upload.int_mode = int_mode
        if message.mission_type != upload.mission_type:
            self._refuse(upload, M.MAV_MISSION_ERROR, f"a {TYPE_NAMES.get(message.mission_type, 'unknown')} item in "
                         f"a {TYPE_NAMES[upload.mission_type]} upload")  # fmt: skip
            return
        order = sequence_result(upload.next_seq, message.seq)
        if order == M.MAV_MISSION_ACCEPTED:
            return  # an item again: the retried request crossed its answer
        if order is not None:
            self._refuse(upload, order, f"item {message.seq} out of sequence, expected {upload.next_seq}")
            return
        item = item_from_message(message, int_mode)
        result = item if isinstance(item, int) else check_item(upload.mission_type, item)
        if isinstance(item, int) or result != M.MAV_MISSION_ACCEPTED:
            self._refuse(upload, result, f"item {message.seq} (command {message.command}, frame {message.frame})")
            return
        if message.current:
            upload.current = message.seq
        upload.items.append(item)
        if upload.complete:
            self._finish(upload)
        else:
            self._request(upload, upload.last_received)

    def _item_outside_upload(self, partner: Partner, message: Any) -> None:
        if self.transfer is not None:
            self.announcer.say(M.MAV_SEVERITY_WARNING, "Mission item refused: another transfer is running",
                               key="mission_busy")  # fmt: skip
            return
        if self._last_upload == (partner, message.mission_type, message.seq + 1):  # the last item again: ACK lost
            self._ack(partner, message.mission_type, M.MAV_MISSION_ACCEPTED)
            return
        self._ack(partner, message.mission_type, M.MAV_MISSION_ERROR, "Mission item ignored: no upload running")

    def _finish(self, upload: Upload) -> None:
        self.transfer = None
        self.flight_stack.handle(StoreMission(upload.mission_type, tuple(upload.items), upload.current))
        self._last_upload = (upload.partner, upload.mission_type, upload.count)
        self._ack(upload.partner, upload.mission_type, M.MAV_MISSION_ACCEPTED)
        self.announcer.say(M.MAV_SEVERITY_INFO, f"{TYPE_NAMES[upload.mission_type].capitalize()} stored: "
                           f"{upload.count} items")  # fmt: skip

    def _request(self, upload: Upload, now: float) -> None:
        upload.last_sent = now
        p, seq, kind = upload.partner, upload.next_seq, upload.mission_type
        encode = p.link.mav.mission_request_int_encode if upload.int_mode else p.link.mav.mission_request_encode
        p.link.queue(encode(p.system, p.component, seq, kind))

    # ---- downloads --------------------------------------------------------------------------------------------------
    def on_request_list(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message):
            return
        partner, kind = partner_of(link, message), message.mission_type
        busy = self._busy_for(partner)
        if busy is not None:
            self._ack(partner, kind, busy, "Mission download refused: a transfer is running")
            return
        if kind not in MISSION_TYPES:
            self._ack(partner, kind, M.MAV_MISSION_UNSUPPORTED, f"Mission type {kind} not supported")
            return
        items = self.stored.items(kind)
        self.transfer = Download(partner, kind, items, last_received=self.clock()) if items else None
        link.queue(link.mav.mission_count_encode(partner.system, partner.component, len(items), kind))

    def on_request_int(self, link: GroundLink, message: Any) -> None:
        self._on_request(link, message, int_mode=True)

    def on_request(self, link: GroundLink, message: Any) -> None:
        self._on_request(link, message, int_mode=False)

    def _on_request(self, link: GroundLink, message: Any, *, int_mode: bool) -> None:
        if not for_us(self.system_id, message):
            return
        partner, download = partner_of(link, message), self.transfer
        if not isinstance(download, Download) or download.partner != partner:
            return  # no download with this client (PX4 ignores these silently: some OSDs send them)
        if message.mission_type != download.mission_type:
            return
        download.last_received = self.clock()
        download.int_mode = int_mode
        if not download.answer(message.seq):
            self.transfer = None
            self.refused += 1
            self._ack(partner, download.mission_type, M.MAV_MISSION_ERROR,
                      f"Mission download: item {message.seq} requested, expected {download.next_seq}")  # fmt: skip
            return
        link.queue(self._item_message(link, download, message.seq))

    def _item_message(self, link: GroundLink, download: Download, seq: int) -> Any:
        item, p = download.items[seq], download.partner
        current = int(download.mission_type == MISSION and seq == self.stored.current)
        params = (item.param1, item.param2, item.param3, item.param4)
        if download.int_mode:
            return link.mav.mission_item_int_encode(p.system, p.component, seq, item.frame, item.command, current,
                                                    item.autocontinue, *params, item.x, item.y, item.z,
                                                    download.mission_type)  # fmt: skip
        x, y = to_float_coordinates(item)
        return link.mav.mission_item_encode(p.system, p.component, seq, FLOAT_FRAME_OF.get(item.frame, item.frame),
                                            item.command, current, item.autocontinue, *params, x, y, item.z,
                                            download.mission_type)  # fmt: skip

    # ---- acknowledgements, clear, current ---------------------------------------------------------------------------
    def on_ack(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message):
            return
        transfer = self.transfer
        if transfer is None or transfer.partner != partner_of(link, message):
            return
        if isinstance(transfer, Download):
            self.transfer = None  # the client has what it asked for (or gave up)
        elif message.type == M.MAV_MISSION_OPERATION_CANCELLED:
            self.transfer = None
        elif message.type == M.MAV_MISSION_UNSUPPORTED:  # the client wants the other kind of request (as PX4)
            transfer.int_mode = not transfer.int_mode
            self._request(transfer, self.clock())

    def on_clear_all(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message):
            return
        partner, kind = partner_of(link, message), message.mission_type
        busy = self._busy_for(partner, clearing=True)
        if busy is not None:
            self._ack(partner, kind, busy, "Mission clear refused: a transfer is running")
            return
        if kind not in MISSION_TYPES and kind != M.MAV_MISSION_TYPE_ALL:
            self._ack(partner, kind, M.MAV_MISSION_UNSUPPORTED, f"Mission type {kind} not supported")
            return
        self.flight_stack.handle(ClearMission(kind))
        self._ack(partner, kind, M.MAV_MISSION_ACCEPTED)

    def on_set_current(self, link: GroundLink, message: Any) -> None:
        if not for_us(self.system_id, message):
            return
        if isinstance(self.transfer, Upload):
            self.announcer.say(M.MAV_SEVERITY_WARNING, "Mission current item ignored: upload running",
                               key="mission_busy")  # fmt: skip
            return
        result, reason = self.flight_stack.handle(SetMissionCurrent(message.seq)) or (M.MAV_RESULT_FAILED, None)
        if result != M.MAV_RESULT_ACCEPTED:
            self.announcer.say(M.MAV_SEVERITY_WARNING, reason or f"Mission item {message.seq} not set",
                               key="mission_current")  # fmt: skip

    def on_write_partial_list(self, link: GroundLink, message: Any) -> None:
        if for_us(self.system_id, message):  # PX4 has no partial uploads either
            self._ack(partner_of(link, message), message.mission_type, M.MAV_MISSION_UNSUPPORTED,
                      "Partial mission uploads not supported: upload the whole list")  # fmt: skip

    def _busy_for(self, partner: Partner, *, clearing: bool = False) -> int | None:
        """None when `partner` may start a transfer (or clear) now, else the MISSION_ACK result refusing it."""
        transfer = self.transfer
        if transfer is None:
            return None
        if isinstance(transfer, Download) and (transfer.all_sent or transfer.partner == partner):
            self.transfer = None  # finished without its ACK, or the client starts over (as PX4)
            return None
        if transfer.partner != partner:
            return M.MAV_MISSION_DENIED
        if isinstance(transfer, Upload) and transfer.next_seq == 0 and not clearing:
            return None  # MISSION_COUNT again: our first request was lost
        return M.MAV_MISSION_ERROR  # the same client, mid-upload (PX4: "Busy")

    def _ack(self, partner: Partner, mission_type: int, result: int, reason: str | None = None) -> None:
        partner.link.queue(partner.link.mav.mission_ack_encode(partner.system, partner.component, result,
                                                               mission_type))  # fmt: skip
        if reason is not None:
            self.announcer.say(M.MAV_SEVERITY_WARNING, f"{reason} ({result_name(result)})", key="mission_refused")

    def _refuse(self, upload: Upload, result: int, why: str) -> None:
        self.transfer = None
        self.refused += 1
        self._ack(upload.partner, upload.mission_type, result, f"{TYPE_NAMES[upload.mission_type].capitalize()} "
                  f"upload refused: {why}; stored list unchanged")  # fmt: skip

    # ---- per step ---------------------------------------------------------------------------------------------------
    def tick(self) -> None:
        """Retries and time-outs of the running transfer (each step)."""
        transfer = self.transfer
        if transfer is None:
            return
        now = self.clock()
        if transfer.timed_out(now):
            self.transfer = None
            if isinstance(transfer, Download) and transfer.all_sent:
                return  # the client has every item and did not say so: nothing lost
            self.refused += 1
            self._ack(
                transfer.partner,
                transfer.mission_type,
                M.MAV_MISSION_OPERATION_CANCELLED,
                f"Mission {'upload' if isinstance(transfer, Upload) else 'download'}: operation timeout",
            )
        elif isinstance(transfer, Upload) and transfer.retry_due(now):
            self._request(transfer, now)

    def publish(self, status: VehicleStatus) -> None:
        """MISSION_CURRENT when the current item, the count or the state changed; MISSION_ITEM_REACHED when an
        item was reached (the 1 Hz MISSION_CURRENT is a stream, messages.py)."""
        m = status.missions
        current = (m.current, len(m.mission), m.state)
        if current != self._current_sent:
            self._current_sent = current
            self.router.queue_all(lambda link: messages.mission_current(link.mav, status))
        if m.reached_count != self._reached_sent:
            self._reached_sent = m.reached_count
            if m.reached >= 0:
                self.router.queue_all(lambda link: link.mav.mission_item_reached_encode(m.reached))
