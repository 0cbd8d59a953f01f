"""The state of one mission transfer (an upload or a download) between the vehicle and one client, and the pure
rules the mission protocol (missions.py) applies to it. No sockets, no clock of its own: times are passed in
(seconds of the wall clock: the partner is a program that runs in wall time, while a lockstep simulation can
run many times faster than that).

    upload:   MISSION_COUNT -> (MISSION_REQUEST_INT seq -> MISSION_ITEM_INT seq)* -> MISSION_ACK
    download: MISSION_REQUEST_LIST -> MISSION_COUNT -> (MISSION_REQUEST_INT seq -> MISSION_ITEM_INT seq)* -> MISSION_ACK

As PX4 (mavlink_mission.cpp): an unanswered request is sent again every RETRY_S, and a transfer with nothing
received from its partner for TIMEOUT_S is abandoned ("Operation timeout"); the stored lists are untouched
until an upload is complete.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from autopilot.topics.mission_items import MissionItem, from_float_coordinates
from transport.mavlink import mavlink as M

RETRY_S = 0.25  # PX4's MAVLINK_MISSION_RETRY_TIMEOUT_DEFAULT
TIMEOUT_S = 5.0  # PX4's MAVLINK_MISSION_PROTOCOL_TIMEOUT_DEFAULT


@dataclass(frozen=True)
class Partner:
    """Who a transfer is with: the link it came on and the client's system and component ids."""

    link: Any  # the GroundLink (compared by identity)
    system: int
    component: int


@dataclass
class Upload:
    partner: Partner
    mission_type: int
    count: int
    started: float
    int_mode: bool = True  # ask with MISSION_REQUEST_INT (False after a legacy MISSION_ITEM, as PX4)
    items: list[MissionItem] = field(default_factory=list)
    current: int = 0  # the item marked current in the upload
    last_sent: float = 0.0
    last_received: float = 0.0

    @property
    def next_seq(self) -> int:
        return len(self.items)

    @property
    def complete(self) -> bool:
        return len(self.items) == self.count

    def retry_due(self, now: float) -> bool:
        return now - self.last_sent >= RETRY_S

    def timed_out(self, now: float) -> bool:
        return now - self.last_received >= TIMEOUT_S


@dataclass
class Download:
    partner: Partner
    mission_type: int
    items: tuple[MissionItem, ...]
    int_mode: bool = True
    next_seq: int = 0  # the request expected next (seq - 1 is answered again)
    last_received: float = 0.0

    @property
    def all_sent(self) -> bool:
        return self.next_seq >= len(self.items)

    def timed_out(self, now: float) -> bool:
        return now - self.last_received >= TIMEOUT_S

    def answer(self, seq: int) -> bool:
        """A request for `seq`: True if it is the expected one (or the last one again), which is then sent."""
        if seq == self.next_seq and seq < len(self.items):
            self.next_seq += 1
            return True
        return 0 <= seq == self.next_seq - 1


Transfer = Upload | Download


def item_from_message(message: Any, int_mode: bool) -> MissionItem | int:
    """The MissionItem a MISSION_ITEM_INT (int_mode) or legacy MISSION_ITEM carries, or the MAV_MISSION_RESULT
    refusing its coordinates (legacy NaN/infinite x, y)."""
    if int_mode:
        x, y = int(message.x), int(message.y)
    else:
        converted = from_float_coordinates(message.frame, float(message.x), float(message.y))
        if isinstance(converted, int):
            return converted
        x, y = converted
    return MissionItem(message.frame, message.command, message.autocontinue, float(message.param1),
                       float(message.param2), float(message.param3), float(message.param4), x, y,
                       float(message.z))  # fmt: skip


def sequence_result(expected: int, seq: int) -> int | None:
    """None: the item to take; ACCEPTED: an old item again (a retried request crossed its answer: ignored, as PX4);
    INVALID_SEQUENCE: an item beyond the one requested (items skipped: refused)."""
    if seq == expected:
        return None
    if seq < expected:
        return M.MAV_MISSION_ACCEPTED
    return M.MAV_MISSION_INVALID_SEQUENCE
