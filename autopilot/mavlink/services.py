"""The MAVLink services together, as the plant loop drives them once per plant step:

    receive(now)     the datagrams waiting on the ground links, each message to its service; what a client asks
                     becomes a typed request to the flight stack (autopilot/topics/requests.py)
    publish(status)  the flight stack's snapshot out: its events as STATUSTEXT, answered injections as
                     COMMAND_ACK, a HEARTBEAT when arming or mode changed, the telemetry streams that are due
                     (at the steps where streams_due() or the flight stack has news; flush() at the others)
    hold(...)        --offboard-lockstep: serve the links while the simulation waits for stamped set-points

Every input is untrusted: the parser drops and counts bad frames, the services check what they decode and
refuse with a reason, and a service's bug is counted and said, never allowed to stop the flight.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any

from autopilot.mavlink import messages
from autopilot.mavlink.commands import CommandService
from autopilot.mavlink.follow_target import FollowTargetService
from autopilot.mavlink.ftp import FtpService
from autopilot.mavlink.ftp_protocol import FileRoot
from autopilot.mavlink.log_download import LogDownloadService
from autopilot.mavlink.manual_control import ManualControlService
from autopilot.mavlink.missions import MissionService
from autopilot.mavlink.offboard import OffboardService
from autopilot.mavlink.offboard_attitude import OffboardAttitudeService
from autopilot.mavlink.parameters import ParameterService
from autopilot.mavlink.router import GroundLink, Router
from autopilot.mavlink.signing import SigningService
from autopilot.mavlink.statustext import Announcer, StatustextSink
from autopilot.mavlink.view import StatusView
from autopilot.storage.parameters import ParameterStore
from autopilot.storage.vehicle_files import VehicleFiles
from autopilot.topics.flight_mode import ModeId
from autopilot.topics.home_position import HomePosition
from autopilot.topics.missions import Missions
from autopilot.topics.requests import GcsHeartbeat, RequestHandler
from autopilot.topics.vehicle_status import VehicleStatus
from transport.geodesy import Home
from transport.mavlink import mavlink as M

INPUT_BUDGET_S = 0.0002  # of input handling per step: a flood cannot starve the control loop
HOLD_POLL_MS = 100  # --offboard-lockstep: a held step waits for datagrams this long between checks for a stop,
HOLD_RESEND_S = 1.0  # says where the simulation stands again after this long without an answer,
HOLD_NOTICE_S = 5.0  # and tells the terminal once after this long

Handler = Callable[[GroundLink, Any], None]


class MavlinkServices:
    def __init__(self, router: Router, params: ParameterStore, flight_stack: RequestHandler, *, system_id: int,
                 home: Home, missions: Missions, modes: tuple[ModeId, ...], events_publisher: Any | None = None,
                 quiet: bool = False, files: FileRoot | None = None, logs: VehicleFiles | None = None,
                 statustext_sink: StatustextSink | None = None,
                 logs_finishing: Callable[[], bool] = lambda: False) -> None:  # fmt: skip
        """missions: the stored lists as loaded from the mission file at start (served until the first publish);
        modes: the vehicle's flight modes (the navigator's table), which ground stations may choose; files: what
        MAVLink FTP serves (None: FTP is not answered); logs: the ULogs log download lists (None: an empty list);
        statustext_sink: told every STATUSTEXT said (the logger); logs_finishing: True while a log that has ended
        is still being written (the logger's), which a log listing waits for."""
        self.router = router
        self.flight_stack = flight_stack
        self.view = StatusView(loaded_missions=missions)
        self._announced_home: HomePosition | None = None
        self.announcer = Announcer(router, self.view.clock, events_publisher, quiet, statustext_sink)
        self.commands = CommandService(
            flight_stack, self.view, self.announcer, system_id=system_id, home=home, modes=modes
        )
        self.offboard = OffboardService(flight_stack, self.view, self.announcer, system_id=system_id, origin=home)
        self.offboard_attitude = OffboardAttitudeService(flight_stack, self.announcer, system_id=system_id)
        self.manual_control = ManualControlService(flight_stack, self.announcer, system_id=system_id)
        self.follow_target = FollowTargetService(flight_stack, self.view, self.announcer, origin=home)
        self.parameters = ParameterService(params, router, self.announcer, system_id=system_id)
        self.missions = MissionService(flight_stack, self.view, router, self.announcer, system_id=system_id)
        self.signing = SigningService(params, router, self.announcer, system_id=system_id)
        self.ftp = None if files is None else FtpService(files, system_id=system_id)
        self.log_download = (
            None if logs is None else LogDownloadService(logs, system_id=system_id, finishing=logs_finishing)
        )
        self.holds = 0  # --offboard-lockstep: steps held for set-points, and the wall time spent holding
        self.hold_wall_s = 0.0
        self._heartbeat_version = 0
        self._handlers: dict[str, Handler] = {
            "HEARTBEAT": self._on_heartbeat,
            "COMMAND_LONG": self.commands.on_command_long,
            "COMMAND_INT": self.commands.on_command_int,
            "SET_MODE": self.commands.on_set_mode,
            "SET_POSITION_TARGET_LOCAL_NED": self.offboard.on_position_target_local,
            "SET_POSITION_TARGET_GLOBAL_INT": self.offboard.on_position_target_global,
            "SET_ATTITUDE_TARGET": self.offboard_attitude.on_attitude_target,
            "MANUAL_CONTROL": self.manual_control.on_manual_control,
            "FOLLOW_TARGET": self.follow_target.on_follow_target,
            "PARAM_REQUEST_LIST": self.parameters.on_request_list,
            "PARAM_REQUEST_READ": self.parameters.on_request_read,
            "PARAM_SET": self.parameters.on_set,
            "MISSION_REQUEST_LIST": self.missions.on_request_list,
            "MISSION_REQUEST_INT": self.missions.on_request_int,
            "MISSION_REQUEST": self.missions.on_request,
            "MISSION_COUNT": self.missions.on_count,
            "MISSION_ITEM_INT": self.missions.on_item_int,
            "MISSION_ITEM": self.missions.on_item,
            "MISSION_ACK": self.missions.on_ack,
            "MISSION_CLEAR_ALL": self.missions.on_clear_all,
            "MISSION_SET_CURRENT": self.missions.on_set_current,
            "MISSION_WRITE_PARTIAL_LIST": self.missions.on_write_partial_list,
            "TIMESYNC": self._on_timesync,
            "SETUP_SIGNING": self.signing.on_setup_signing,
        }
        if self.ftp is not None:
            self._handlers["FILE_TRANSFER_PROTOCOL"] = self.ftp.on_file_transfer_protocol
        if self.log_download is not None:
            self._handlers |= {
                "LOG_REQUEST_LIST": self.log_download.on_request_list,
                "LOG_REQUEST_DATA": self.log_download.on_request_data,
                "LOG_REQUEST_END": self.log_download.on_request_end,
                "LOG_ERASE": self.log_download.on_erase,
            }

    @property
    def handled_messages(self) -> tuple[str, ...]:
        """The names of the messages the services take (the dispatch table); any other is counted and ignored."""
        return tuple(self._handlers)

    @property
    def handled_commands(self) -> tuple[int, ...]:
        """The MAV_CMD ids that COMMAND_LONG and COMMAND_INT take; any other is answered UNSUPPORTED."""
        return self.commands.handled_commands

    # ---- per step ---------------------------------------------------------------------------------------------
    def receive(self, now_usec: int, wait_ms: int = 0, budget_s: float = INPUT_BUDGET_S) -> bool:
        """Handle the datagrams waiting on the links (waiting up to wait_ms for the first); True if any."""
        self.view.now_usec = now_usec
        self.parameters.check_saved()
        ready = self.router.ready(wait_ms)
        if ready:
            deadline = time.perf_counter() + budget_s
            for link in ready:
                for data, sender in link.receive(deadline):
                    self._datagram(link, data, sender)
        self.missions.tick()
        if self.ftp is not None:
            self.ftp.send()
        if self.log_download is not None:
            self.log_download.send()
        return bool(ready)

    def publish(self, status: VehicleStatus) -> None:
        self.view.status = status
        self.view.now_usec = status.time_usec
        for event in status.events:
            self.announcer.say(event.severity, event.text, event.key)
        if status.injections:
            self.commands.injections_answered(status.injections)
        if status.state_version != self._heartbeat_version:  # a HEARTBEAT right after every change, as PX4
            self._heartbeat_version = status.state_version
            self.router.queue_all(lambda link: messages.heartbeat(link.mav, status))
        self.missions.publish(status)
        if status.home is not self._announced_home:  # a new home goes out at once, as PX4's stream sends it
            self._announced_home = home = status.home
            self.router.queue_all(lambda link: messages.home_position(link.mav, home, status.time_usec))
        for link in self.router.links:
            for msgid in link.streams.due(status.time_usec, idle=not link.clients):
                message = messages.build(msgid, link.mav, status)
                if message is not None:
                    link.queue(message)
        self.router.flush()

    def streams_due(self, now_usec: int) -> bool:
        """A telemetry stream is due on some link at now_usec: the next publish() has something to send."""
        return any(link.streams.next_any_due <= now_usec for link in self.router.links)

    def flush(self) -> None:
        """Send what the services queued this step (answers to requests) on a step without a publish()."""
        self.router.flush()

    def hold(self, time_usec: int, released: Callable[[], bool], should_stop: Callable[[], bool]) -> None:
        """--offboard-lockstep: while not `released()` (no stamped set-point covers `time_usec`), hold here (the
        plant waits for this step's answer) and serve the links. Each wait starts with a SYSTEM_TIME
        (time_boot_ms = now) on every link, which tells a scripted client where the simulation stands; it is
        repeated each HOLD_RESEND_S without input."""
        if released():
            return
        self.holds += 1
        waiting_since = sent = time.monotonic()
        said = False
        self._send_system_time(time_usec)
        while not released() and not should_stop():
            ready = self.receive(time_usec, HOLD_POLL_MS, HOLD_POLL_MS / 1000)
            self.router.flush()
            now = time.monotonic()
            if not ready and now - sent >= HOLD_RESEND_S:
                self._send_system_time(time_usec)
                sent = now
                if not said and now - waiting_since >= HOLD_NOTICE_S:
                    said = True
                    print(
                        f"vtol-autopilot: --offboard-lockstep: holding the simulation at {time_usec / 1e6:.3f} s "
                        "until a client streams set-points stamped with time_boot_ms",
                        file=sys.stderr,
                        flush=True,
                    )
        self.hold_wall_s += time.monotonic() - waiting_since

    def restart(self, now_usec: int) -> None:
        """The simulation clock went back: restart the stream schedules and the notices."""
        self.view.now_usec = now_usec
        for link in self.router.links:
            link.streams.restart(now_usec)
        self.announcer.restart()

    def say(self, severity: int, text: str) -> None:
        self.announcer.say(severity, text)

    # ---- receiving ----------------------------------------------------------------------------------------------
    def _datagram(self, link: GroundLink, data: bytes, sender: tuple[str, int]) -> None:
        messages_in = link.link.parse(data)
        if messages_in and link.heard(sender):
            link.streams.restart(self.view.now_usec)  # the first client: full stream rates from now
        for message in messages_in:
            link.counters.received += 1
            kind = message.get_type()
            handler = self._handlers.get(kind)
            if handler is None:
                link.counters.ignored[kind] += 1
                continue
            if not self.signing.admits(link, message):
                continue
            try:
                handler(link, message)
            except Exception as exc:  # a service's bug must never stop the flight: count it and say it
                link.counters.ignored[f"error:{kind}"] += 1
                self.announcer.say(M.MAV_SEVERITY_ERROR, f"{kind} not handled: {type(exc).__name__}: {exc}",
                                   key=f"error:{kind}")  # fmt: skip

    def _on_heartbeat(self, link: GroundLink, message: Any) -> None:
        """Besides teaching the link its client's address: a ground station's says the data link is alive."""
        if message.type == M.MAV_TYPE_GCS:
            self.flight_stack.handle(GcsHeartbeat())

    def _on_timesync(self, link: GroundLink, message: Any) -> None:
        if message.tc1 == 0:
            link.queue(link.mav.timesync_encode(self.view.now_usec * 1000, message.ts1))

    def _send_system_time(self, time_usec: int) -> None:
        self.router.queue_all(lambda link: messages.system_time(link.mav, time_usec))
        self.router.flush()

    # ---- the end ------------------------------------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        return (
            {link.name.lower(): link.summary() for link in self.router.links}
            | {
                "setpoints_dropped": self.offboard.dropped + self.offboard_attitude.dropped,
                "follow_targets_dropped": self.follow_target.dropped,
                "notices_suppressed": self.announcer.suppressed,
                "lockstep_holds": self.holds,
                "lockstep_hold_wall_s": round(self.hold_wall_s, 3),
            }
            | self.signing.summary()
            | ({} if self.ftp is None else {"ftp": self.ftp.summary()})
        )

    def close(self) -> None:
        if self.ftp is not None:
            self.ftp.close()
        if self.log_download is not None:
            self.log_download.close()
        self.router.close()
