"""What a ground station can ask of the flight stack, as typed requests (the MAVLink services make them).

The services decode and check the MAVLink side of a request (target ids, integer parameters, frames) and hand
the flight stack one of these; the flight stack answers with a Reply (MAV_RESULT and, for a refusal, the
reason that goes to the ground station as STATUSTEXT), or with None when the answer comes later (a failure
injection is answered once the plant has acknowledged it; the outcome shows in the VehicleStatus).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from aircraft.failures import Failure
from autopilot.topics.home_position import HomePosition
from autopilot.topics.mission_items import MissionItem
from autopilot.topics.region_of_interest import RegionOfInterest
from autopilot.topics.yaw_setpoint import YawSetpoint

Reply = tuple[int, str | None]  # (MAV_RESULT, reason or None)


FORCE_MAGIC = 21196  # MAV_CMD_COMPONENT_ARM_DISARM param2: arm or disarm without the checks (PX4)


@dataclass(frozen=True)
class Arm:
    force: bool = False  # param2 = FORCE_MAGIC: skip the checks


@dataclass(frozen=True)
class Disarm:
    force: bool = False


@dataclass(frozen=True)
class Takeoff:
    altitude_above_home: float | None  # m; None: MIS_TAKEOFF_ALT


@dataclass(frozen=True)
class Land:
    pass


@dataclass(frozen=True)
class SetHome:
    """MAV_CMD_DO_SET_HOME: `home` (checked); `current` when it is where the vehicle is (param1 = 1)."""

    home: HomePosition
    current: bool


@dataclass(frozen=True)
class SetMode:
    mode: str  # one of the commander's modes (Hold, Takeoff, Land, Offboard)


@dataclass(frozen=True)
class Transition:
    target: int  # MAV_VTOL_STATE_MC or MAV_VTOL_STATE_FW


@dataclass(frozen=True)
class OffboardVelocity:
    """A finite velocity set-point (m/s) received now; `body` when it is in a yaw-rotated (body) frame; `yaw` the
    finite heading (rad, NED in every frame, as PX4 takes it) and/or yaw rate (rad/s), None when both are ignored."""

    velocity: np.ndarray
    body: bool
    stamp_ms: int | None  # its time_boot_ms (with --offboard-lockstep it takes effect then)
    yaw: YawSetpoint | None = None


@dataclass(frozen=True)
class OffboardPosition:
    """A finite position set-point (m, NED from home; with `relative`, an offset from where the vehicle is, rotated
    by its yaw when `body`) and a velocity feed-forward (m/s, NED or body like the position)."""

    position: np.ndarray
    velocity: np.ndarray
    relative: bool
    body: bool
    yaw: YawSetpoint | None = None  # as OffboardVelocity's


@dataclass(frozen=True)
class OffboardAttitude:
    """SET_ATTITUDE_TARGET: a finite attitude (roll, pitch, yaw rad) or, when the attitude is ignored, body rates
    (rad/s), and a collective thrust (0..1 of the rotors' full thrust; None: the last one). Checked for range by
    the commander (clamped and reported)."""

    euler: np.ndarray | None
    body_rates: np.ndarray | None
    thrust: float | None


@dataclass(frozen=True)
class ManualControlInput:
    """MANUAL_CONTROL (a virtual RC) normalised: pitch, roll, yaw -1..1, throttle 0..1 (0.5 centre)."""

    pitch: float = 0.0
    roll: float = 0.0
    throttle: float = 0.5
    yaw: float = 0.0


@dataclass(frozen=True)
class FollowTargetReport:
    """FOLLOW_TARGET, checked: where the target is now (finite, m, NED from the local origin) and its velocity
    (finite, m/s, NED; None when the message gives none)."""

    position: np.ndarray
    velocity: np.ndarray | None


@dataclass(frozen=True)
class InjectFailure:
    """MAV_CMD_INJECT_FAILURE, checked against the failure vocabulary; `ticket` names it in the outcome."""

    failure: Failure
    ticket: int


@dataclass(frozen=True)
class StoreMission:
    """A complete, checked upload (mission protocol): replaces the list of `mission_type`; `current` is the item
    the upload marked current (0 when none)."""

    mission_type: int  # MAV_MISSION_TYPE_MISSION, _FENCE or _RALLY
    items: tuple[MissionItem, ...]
    current: int = 0


@dataclass(frozen=True)
class ClearMission:
    mission_type: int  # one type, or MAV_MISSION_TYPE_ALL


@dataclass(frozen=True)
class SetMissionCurrent:
    seq: int


@dataclass(frozen=True)
class StartMission:
    """MAV_CMD_MISSION_START (or Mission mode): fly the stored mission from its current item."""


@dataclass(frozen=True)
class ReturnToLaunch:
    pass


@dataclass(frozen=True)
class Reposition:
    """MAV_CMD_DO_REPOSITION: fly to `position` (NED from home) and Hold there; `speed` None: the default; `yaw` the
    heading (rad) on the way and there, None: the velocity controllers' own rule."""

    position: np.ndarray
    speed: float | None
    yaw: float | None = None


@dataclass(frozen=True)
class TurnTo:
    """MAV_CMD_CONDITION_YAW: turn to `angle` (rad, finite) in Hold; `relative`: by `angle` from the current heading,
    `clockwise` or not."""

    angle: float
    relative: bool
    clockwise: bool


@dataclass(frozen=True)
class ChangeSpeed:
    """MAV_CMD_DO_CHANGE_SPEED: the cruise speed (m/s, finite, > 0) of the legs flown from now; None: the defaults."""

    speed: float | None


@dataclass(frozen=True)
class Orbit:
    """MAV_CMD_DO_ORBIT: circle `center` (NE; None: here) at `down` (None: the current altitude)."""

    center: np.ndarray | None
    down: float | None
    radius: float  # m, > 0
    clockwise: bool
    speed: float  # m/s
    yaw_behaviour: int = 0  # ORBIT_YAW_BEHAVIOUR (0: HOLD_FRONT_TO_CIRCLE_CENTER, PX4's default)


@dataclass(frozen=True)
class SetRegionOfInterest:
    """MAV_CMD_DO_SET_ROI_LOCATION / _WPNEXT_OFFSET / _NONE, DO_SET_ROI: where the nose points on a mission's legs
    (None: the items' own yaw)."""

    roi: RegionOfInterest | None


@dataclass(frozen=True)
class OutputTest:
    """MAV_CMD_DO_MOTOR_TEST / MAV_CMD_ACTUATOR_TEST (autopilot/commander/output_tests.py): drive motor `index` (0 ... 3) or
    servo `index` (0 ... 7) at `value` for `timeout_s`; `value` None releases the output."""

    motor: bool
    index: int
    value: float | None
    timeout_s: float


@dataclass(frozen=True)
class FlightTermination:
    """MAV_CMD_DO_FLIGHTTERMINATION: terminate (motors off) when `on`, else clear a termination."""

    on: bool


@dataclass(frozen=True)
class GcsHeartbeat:
    """A HEARTBEAT from a ground station (MAV_TYPE_GCS) arrived now: the data link is alive (NAV_DLL_ACT)."""


@dataclass(frozen=True)
class Reboot:
    """MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN param1 1: restart the autopilot (disarmed only)."""


@dataclass(frozen=True)
class PreflightStorage:
    """MAV_CMD_PREFLIGHT_STORAGE param1, PX4's PREFLIGHT_STORAGE_PARAMETER_ACTION: 0 read the parameter file again,
    1 write it, 2 reset every parameter to its default, 3 reset the sensor calibrations (CAL_ACC*, CAL_GYRO*,
    CAL_MAG*), 4 reset every parameter."""

    action: int


@dataclass(frozen=True)
class Calibrate:
    """MAV_CMD_PREFLIGHT_CALIBRATION: start calibrating `sensor` (autopilot/commander/calibration.py's Sensor
    values: "gyro", "level", "accel", "mag"), or None: cancel the running one (every param 0)."""

    sensor: str | None


Request = (Arm | Disarm | Takeoff | Land | SetMode | Transition | OffboardVelocity | OffboardPosition
           | OffboardAttitude | ManualControlInput | FollowTargetReport | InjectFailure
           | StoreMission | ClearMission | SetMissionCurrent | StartMission | ReturnToLaunch | Reposition | ChangeSpeed
           | Orbit | GcsHeartbeat | SetHome | TurnTo | SetRegionOfInterest | FlightTermination
           | OutputTest | Reboot | PreflightStorage | Calibrate)  # fmt: skip


class RequestHandler(Protocol):
    """The flight stack as the MAVLink services see it."""

    def handle(self, request: Request) -> Reply | None: ...
