"""Telemetry stream schedules, one per link, in simulation time (MAV_CMD_SET_MESSAGE_INTERVAL changes them).

Until a client speaks on a link no stream runs faster than IDLE_INTERVAL_USEC there, which keeps an unconnected
autopilot cheap; the first client restarts the schedule at full rates.
"""

from __future__ import annotations

from collections.abc import Iterator

from transport.mavlink import mavlink as M

MIN_INTERVAL_USEC = 2500  # one plant step: the fastest a stream can go
IDLE_INTERVAL_USEC = 500_000  # 2 Hz until a client speaks
NEVER = 1 << 62

# The streams and their default rates (Hz) on the GCS link, as PX4 sends them to a ground station.
DEFAULT_RATES_HZ: dict[int, float] = {
    M.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    M.MAVLINK_MSG_ID_SYS_STATUS: 2.0,
    M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 2.0,
    M.MAVLINK_MSG_ID_ATTITUDE: 50.0,
    M.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: 50.0,
    M.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 30.0,
    M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 30.0,
    M.MAVLINK_MSG_ID_VFR_HUD: 10.0,
    M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: 20.0,
    M.MAVLINK_MSG_ID_GPS_RAW_INT: 5.0,
    M.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0,
    M.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
    M.MAVLINK_MSG_ID_SYSTEM_TIME: 1.0,
    M.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,
}
# The streams PX4 sends only on its onboard (API) link: off on the GCS link until a client asks for them
# (MAV_CMD_SET_MESSAGE_INTERVAL), on the API link at PX4's onboard rates.
ONBOARD_RATES_HZ: dict[int, float] = {
    M.MAVLINK_MSG_ID_HIGHRES_IMU: 50.0,
}
STREAMS = frozenset(DEFAULT_RATES_HZ) | frozenset(ONBOARD_RATES_HZ)  # every stream a client may set an interval of


def link_rates(onboard: bool) -> dict[int, float]:
    """A link's default rates (Hz) by message id: the GCS link's, or with `onboard` the API link's."""
    return DEFAULT_RATES_HZ | ONBOARD_RATES_HZ if onboard else dict(DEFAULT_RATES_HZ)


def interval_usec(rate_hz: float) -> int:
    return int(round(1e6 / rate_hz))


class StreamSchedule:
    """Which stream is due when, on one link."""

    def __init__(self, defaults: dict[int, float]) -> None:
        """`defaults`: the link's rates (Hz) by message id (link_rates)."""
        self.defaults = {msgid: interval_usec(rate) for msgid, rate in defaults.items()}
        self.intervals = dict(self.defaults)
        self.next_due = {msgid: 0 for msgid in self.intervals}
        self.next_any_due = 0

    def default_interval(self, msgid: int) -> int:
        """A stream's default interval on this link (us; 0: off until asked for)."""
        return self.defaults.get(msgid, 0)

    def set_interval(self, msgid: int, interval: int, now_usec: int) -> None:
        """A stream's interval (us; 0 or less stops it), from now on."""
        if interval <= 0:
            self.intervals.pop(msgid, None)
            self.next_due.pop(msgid, None)
        else:
            self.intervals[msgid] = interval
            self.next_due[msgid] = now_usec
        self.next_any_due = min(self.next_due.values(), default=NEVER)

    def restart(self, now_usec: int) -> None:
        for msgid in self.next_due:
            self.next_due[msgid] = now_usec
        self.next_any_due = now_usec

    def due(self, now_usec: int, idle: bool) -> Iterator[int]:
        """The streams due now (each rescheduled as it is yielded); `idle`: no client yet, 2 Hz at most."""
        if now_usec < self.next_any_due:
            return
        next_any = NEVER
        for msgid, due in self.next_due.items():
            if now_usec >= due:
                yield msgid
                interval = self.intervals[msgid]
                if idle and interval < IDLE_INTERVAL_USEC:
                    interval = IDLE_INTERVAL_USEC
                due += interval
                if due <= now_usec:  # fell behind (or restarted): from now on
                    due = now_usec + interval
                self.next_due[msgid] = due
            if due < next_any:
                next_any = due
        self.next_any_due = next_any
