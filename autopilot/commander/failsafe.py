"""PX4's failsafes as its commander/failsafe does them (docs/failsafes.md): each commander tick the conditions are
checked from the vehicle's status, and when one starts to hold, the action PX4's parameter names for it is chosen:

    offboard loss      Offboard with no set-point for COM_OF_LOSS_T         COM_OBL_RC_ACT
    position loss      the GPS OFF (injected) for COM_POS_FS_DELAY          Descend (PX4's mode fallback)
    data-link loss     no GCS HEARTBEAT for COM_DL_LOSS_T (after a first)   NAV_DLL_ACT (ignored in Land)
    geofence breach    GF_MAX_HOR_DIST, GF_MAX_VER_DIST, the fence items    GF_ACTION
    manual control     Position/Altitude with no MANUAL_CONTROL for          NAV_RCL_ACT
    loss               COM_RC_LOSS_T
    low battery        the battery's warning level rises (BAT_*_THR)         COM_LOW_BAT_ACT (critical, emergency)

A condition acts when it starts (PX4: the action is cleared by a mode change, so a user can fly out of it); its
cause is said as a STATUSTEXT, and the commander switches modes and says "Failsafe activated" (failsafe_reaction.py).
The offboard loss's manual fallbacks, PX4's Position and Altitude, need manual control (MANUAL_CONTROL heard in
the last COM_RC_LOSS_T): without it they fall back to Hold, as PX4's chain (Altitude, Stabilized, Hold) does when
there is no RC; Stabilized, which this vehicle has not, is Hold.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from aircraft.failures import Failure, FailureUnit, failed_sensors
from autopilot.commander.home import HomeKeeper
from autopilot.navigator.geofence import Fence, breach, fence_from_items
from autopilot.navigator.modes.altitude import ALTITUDE
from autopilot.navigator.modes.hold import HOLD
from autopilot.navigator.modes.land import LAND
from autopilot.navigator.modes.position import POSITION
from autopilot.navigator.modes.rtl import RETURN
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.battery import BatteryWarning
from transport.mavlink import mavlink

NONE, WARN, TERMINATE, DISARM = "None", "Warn", "Terminate", "Disarm"  # the actions that are not modes
DESCEND = "Descend"  # Land with no horizontal position control (PX4 reports it as AUTO.LAND too)
OFFBOARD_LOSS_ACTIONS = {0: POSITION, 1: ALTITUDE, 2: HOLD, 3: RETURN, 4: LAND, 5: HOLD}  # COM_OBL_RC_ACT
NEEDS_MANUAL_CONTROL = (POSITION, ALTITUDE)  # without it PX4 falls back along Altitude, Stabilized, to Hold
DATALINK_LOSS_ACTIONS = {0: NONE, 1: HOLD, 2: RETURN, 3: LAND}  # NAV_DLL_ACT
GEOFENCE_ACTIONS = {0: NONE, 1: WARN, 2: HOLD, 3: RETURN, 4: TERMINATE, 5: LAND}  # GF_ACTION
MANUAL_LOSS_ACTIONS = {0: NONE, 1: HOLD, 2: RETURN, 3: LAND, 4: HOLD, 5: TERMINATE, 6: DISARM}  # NAV_RCL_ACT
LOW_BATTERY_ACTIONS = {0: (WARN, WARN), 1: (RETURN, RETURN), 2: (LAND, LAND), 3: (RETURN, LAND)}  # COM_LOW_BAT_ACT:
# the actions at the critical and at the emergency level (the low level only warns)
_CRITICAL, _EMERGENCY = mavlink.MAV_SEVERITY_CRITICAL, mavlink.MAV_SEVERITY_EMERGENCY
BATTERY_REPORTS = {  # PX4's battery check, when the level rises
    BatteryWarning.LOW: (_CRITICAL, "Low battery"),
    BatteryWarning.CRITICAL: (_CRITICAL, "Critical battery"),
    BatteryWarning.EMERGENCY: (_EMERGENCY, "Emergency battery level"),
}
BATTERY_WARNINGS = {  # PX4's failsafe notice when the level's action is a warning
    BatteryWarning.LOW: (mavlink.MAV_SEVERITY_WARNING, "Low battery level, return advised"),
    BatteryWarning.CRITICAL: (_CRITICAL, "Critical battery level, land now"),
    BatteryWarning.EMERGENCY: (_EMERGENCY, "Emergency battery level, land immediately"),
}
BATTERY_CAUSES = {
    BatteryWarning.CRITICAL: "Critical battery level",
    BatteryWarning.EMERGENCY: "Emergency battery level",
}


@dataclass(frozen=True)
class Decision:
    """What a failsafe asks of the commander: an action (a mode, or Warn, Terminate) and why."""

    action: str
    cause: str


@dataclass(frozen=True)
class FailsafeInputs:
    """The vehicle's status as the failsafe checks see it, this tick."""

    now_usec: int
    flying: bool
    mode: str
    position_ned: np.ndarray
    offboard_lost: bool  # in Offboard with no set-point for COM_OF_LOSS_T
    manual_lost: bool = False  # in Position or Altitude with no MANUAL_CONTROL for COM_RC_LOSS_T
    manual_fresh: bool = False  # MANUAL_CONTROL heard in the last COM_RC_LOSS_T (the manual modes can run)
    armed: bool = False
    battery: BatteryWarning = BatteryWarning.NONE  # the battery's warning level now


class Failsafe:
    def __init__(self, params: ParameterStore, missions: MissionStore, homes: HomeKeeper,
                 say: Callable[..., None]) -> None:  # fmt: skip
        self.params = params
        self.missions = missions
        self.homes = homes
        self.say = say
        self.gcs_heard_usec: int | None = None  # the last GCS HEARTBEAT (simulation time)
        self.datalink_lost = False
        self.breached = False
        self.sensors_failed: frozenset[FailureUnit] = frozenset()
        self.position_lost_usec: int | None = None  # when the GPS went OFF
        self._position_failsafe_done = False
        self._failures: list[Failure] = []
        self._fence = Fence((), ())
        self._fence_items: tuple = ()
        self.battery_warning = BatteryWarning.NONE  # as PX4 reports it: while armed it only rises

    # ---- what the links tell ----------------------------------------------------------------------------------
    def gcs_heartbeat(self, now_usec: int) -> None:
        """A HEARTBEAT from a ground station (MAV_TYPE_GCS), on any link, as PX4 counts them."""
        self.gcs_heard_usec = now_usec
        if self.datalink_lost:
            self.datalink_lost = False
            self.say(mavlink.MAV_SEVERITY_INFO, "Data link regained")

    def failure_known(self, failure: Failure) -> None:
        """A failure the plant applied (sensors matter here: the controllers fly on truth)."""
        if failure.sensor:
            self._failures.append(failure)
            self.sensors_failed = failed_sensors(self._failures)

    @property
    def position_lost(self) -> bool:
        """No position estimate: the GPS is OFF (PX4's position modes cannot run)."""
        return FailureUnit.GPS in self.sensors_failed

    def restart(self) -> None:
        """A new plant run: nothing heard yet in its time."""
        self.gcs_heard_usec = None
        self.datalink_lost = False

    # ---- each tick ----------------------------------------------------------------------------------------------
    def check(self, status: FailsafeInputs) -> Decision | None:
        """The decision of a condition that started to hold this tick (the worst first), or None."""
        if status.offboard_lost:
            action = OFFBOARD_LOSS_ACTIONS[self.params.get_int("COM_OBL_RC_ACT")] if status.flying else HOLD
            if action in NEEDS_MANUAL_CONTROL and not status.manual_fresh:
                action = HOLD
            return Decision(action, f"Offboard lost: no set-point for {self.params['COM_OF_LOSS_T']:g} s")
        if status.manual_lost:  # PX4 with NAV_RCL_ACT 0 still leaves a manual mode it cannot fly: Hold
            action = MANUAL_LOSS_ACTIONS[self.params.get_int("NAV_RCL_ACT")] if status.flying else HOLD
            cause = f"Manual control lost: no MANUAL_CONTROL for {self.params['COM_RC_LOSS_T']:g} s"
            return Decision(HOLD if action == NONE else action, cause)
        battery = self._battery(status)
        return self._position(status) or self._geofence(status) or battery or self._datalink(status)

    def _battery(self, status: FailsafeInputs) -> Decision | None:
        """PX4's battery check and failsafe: armed, each rise of the warning level is said, and at the critical and
        emergency levels COM_LOW_BAT_ACT acts (on the ground it only warns). Disarmed, the level follows the battery
        silently."""
        level = status.battery
        rose = level > self.battery_warning
        if status.armed and not rose:
            return None
        self.battery_warning = level
        if not status.armed or not rose:
            return None
        self.say(*BATTERY_REPORTS[level])
        action = WARN
        if level != BatteryWarning.LOW:
            critical, emergency = LOW_BATTERY_ACTIONS[self.params.get_int("COM_LOW_BAT_ACT")]
            action = critical if level == BatteryWarning.CRITICAL else emergency
        if action == WARN or not status.flying:
            self.say(*BATTERY_WARNINGS[level])
            return None
        return Decision(action, BATTERY_CAUSES[level])

    def _position(self, status: FailsafeInputs) -> Decision | None:
        if not self.position_lost:
            self.position_lost_usec = None
            self._position_failsafe_done = False
            return None
        if self.position_lost_usec is None:
            self.position_lost_usec = status.now_usec
            self.say(mavlink.MAV_SEVERITY_CRITICAL, "GPS lost: no position estimate")
        delay_usec = self.params.get_int("COM_POS_FS_DELAY") * 1_000_000
        if self._position_failsafe_done or not status.flying or status.now_usec - self.position_lost_usec < delay_usec:
            return None
        self._position_failsafe_done = True
        return Decision(DESCEND, "Position lost")

    def _datalink(self, status: FailsafeInputs) -> Decision | None:
        timeout_usec = self.params["COM_DL_LOSS_T"] * 1e6
        if self.datalink_lost or self.gcs_heard_usec is None or status.now_usec - self.gcs_heard_usec <= timeout_usec:
            return None
        self.datalink_lost = True
        action = DATALINK_LOSS_ACTIONS[self.params.get_int("NAV_DLL_ACT")]
        if action == NONE or not status.flying or status.mode == LAND:  # PX4 ignores it in Land and on the ground
            self.say(mavlink.MAV_SEVERITY_WARNING, "Connection to ground station lost")
            return None
        return Decision(action, "Connection to ground station lost")

    def fence(self) -> Fence:
        """The zones of the stored fence (made again when a new fence is stored)."""
        items = self.missions.snapshot.fence
        if items is not self._fence_items:
            self._fence_items = items
            self._fence = fence_from_items(items, self.homes.origin)
            for reason in self._fence.ignored:
                self.say(mavlink.MAV_SEVERITY_WARNING, f"Geofence: {reason}: ignored")
        return self._fence

    def outside_fence(self, position_ned: np.ndarray) -> str | None:
        """Why `position_ned` is outside the geofence (None: inside, or GF_ACTION 0 disables the fence)."""
        if GEOFENCE_ACTIONS[self.params.get_int("GF_ACTION")] == NONE:
            return None
        return breach(position_ned, self.fence(), self.params["GF_MAX_HOR_DIST"], self.params["GF_MAX_VER_DIST"],
                      self.homes.position.ned)  # fmt: skip

    def _geofence(self, status: FailsafeInputs) -> Decision | None:
        why = self.outside_fence(status.position_ned) if status.flying else None
        started = why is not None and not self.breached
        self.breached = why is not None
        if not started:
            return None
        return Decision(GEOFENCE_ACTIONS[self.params.get_int("GF_ACTION")], f"Geofence violated: {why}")
