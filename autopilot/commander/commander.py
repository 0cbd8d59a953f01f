"""Arming, the mode choice and its switches, as PX4's commander does them, in simulation time (docs/mavlink.md).

The modes are the navigator's (autopilot/navigator/modes/, one module each with its PX4 custom mode and its entry
rules): the commander chooses the mode, the mode gives the velocity set-point for the flight controller, and its
yaw set-point, shaped into the yaw reference the controllers follow while the set-point is a multicopter's
(navigator/yaw_shaping.py).

On the ground the flight controller does not run: disarmed, the rotors are off; armed, they idle until a
takeoff (Takeoff mode, or an Offboard set-point that climbs), which starts a fresh flight controller
(ground_state.py: lift-offs, touchdowns, the automatic disarms).

Every request answers (MAV_RESULT, reason); a reason goes to the ground station as STATUSTEXT. What the
commander says (`say`) goes to the ground stations as STATUSTEXT too. Arming, modes and takeoff are judged here;
the guided requests (Land, Go-to, Orbit, transition, speed, home, Offboard set-points) in guided_requests.py, the
requests on the outputs (flight termination, motor and actuator tests) in output_requests.py.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from aircraft.failures import Failure
from autopilot.commander.battery_simulator import BatterySimulator
from autopilot.commander.failsafe import Decision, Failsafe, FailsafeInputs
from autopilot.commander.failsafe_reaction import reaction
from autopilot.commander.ground_state import GroundState, landed_state
from autopilot.commander.home import HomeKeeper
from autopilot.commander.land_detector import LandDetector
from autopilot.commander.output_tests import OutputTests
from autopilot.commander.prearm_checks import prearm_refusal
from autopilot.navigator.auto_flight import Circle
from autopilot.navigator.guidance import TICK_S
from autopilot.navigator.mode import FlightMode, ModeEntry
from autopilot.navigator.modes.altitude import ALTITUDE
from autopilot.navigator.modes.hold import HOLD
from autopilot.navigator.modes.mission import MISSION
from autopilot.navigator.modes.offboard import OFFBOARD
from autopilot.navigator.modes.position import POSITION
from autopilot.navigator.modes.takeoff import TAKEOFF
from autopilot.navigator.navigator import Navigator, build_navigator
from autopilot.navigator.yaw_shaping import YawShaper, multicopter_speed
from autopilot.storage.mission_store import MissionStore
from autopilot.storage.parameters import ParameterStore
from autopilot.topics.attitude_target import AttitudeTarget
from autopilot.topics.flight_mode import ModeId
from autopilot.topics.home_position import HomePosition
from autopilot.topics.region_of_interest import RegionOfInterest
from autopilot.topics.requests import FORCE_MAGIC, FollowTargetReport, ManualControlInput, Reply
from autopilot.topics.vehicle_state import VehicleState
from autopilot.topics.vehicle_status import CommanderReport
from autopilot.topics.yaw_setpoint import YawReference
from transport.geodesy import Home
from transport.mavlink import mavlink

ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
TEMPORARILY_REJECTED = mavlink.MAV_RESULT_TEMPORARILY_REJECTED
DENIED = mavlink.MAV_RESULT_DENIED
UNSUPPORTED = mavlink.MAV_RESULT_UNSUPPORTED


HOME_AT_REST_SPEED = 0.5  # m/s: home follows a disarmed vehicle on the ground only when it is this still


class Commander:
    """The vehicle's arming state, mode and ground/air state; velocity set-points at 100 Hz. Its collaborators are
    built by build_commander."""

    def __init__(self, params: ParameterStore, navigator: Navigator, failsafe: Failsafe, homes: HomeKeeper,
                 ground: GroundState, land_detector: LandDetector, battery: BatterySimulator, *, armed: bool,
                 say: Callable[..., None], profile: Callable[[float], np.ndarray] | None = None) -> None:  # fmt: skip
        self.params = params
        self.battery = battery
        self.navigator = navigator
        self.modes = navigator.modes
        self.failsafe = failsafe
        self.homes = homes
        self.ground = ground
        self.land_detector = land_detector
        context = navigator.context
        self.feasibility = context.feasibility
        self.offboard = context.offboard
        self.manual = context.manual
        self.target = context.target
        self.yaw_shaper = YawShaper()
        self.say = say
        self.profile = profile
        self.armed = armed
        self.mode = OFFBOARD if profile is not None else HOLD
        self.started = False
        self.state_version = 1  # counts arming, mode, ground-state and termination changes (each sends a HEARTBEAT)
        self.terminated = False  # flight termination: motors off (disarmed), arming refused until it is cleared
        self.output_tests = OutputTests()  # motor and actuator tests, disarmed
        self._reported_version = 0
        self.now_usec = 0
        self.state = VehicleState()  # the current step's estimate (observe())
        self._start_usec = 0
        self.failsafes = 0

    # ---- state ---------------------------------------------------------------------------------------------
    @property
    def yaw_reference(self) -> YawReference | None:  # the tick's, for the flight controller (None: its own rule)
        return self.yaw_shaper.reference

    @property
    def on_ground(self) -> bool:
        return self.ground.on_ground

    @property
    def controller_reset(self) -> bool:
        """A takeoff began that no fresh flight controller has been started for yet."""
        return self.ground.controller_reset

    def controller_started(self) -> None:
        """The flight stack started a fresh flight controller for the current flight."""
        self.ground.controller_started()

    @property
    def state_changed(self) -> bool:
        """Arming, mode, ground state or flight termination changed since the last report()."""
        return self.state_version != self._reported_version

    def report(self) -> CommanderReport:
        self._reported_version = self.state_version
        return CommanderReport(self.started, self.armed, self.active.id, self.landed_state, self.flying,
                               self.state_version, self.terminated, self.battery.status)  # fmt: skip

    def observe(self, state: VehicleState) -> None:
        """The state estimate of the current plant step (requests are judged against it)."""
        self.state = state
        self.now_usec = state.time_usec

    @property
    def flying(self) -> bool:
        """The flight controller runs (armed and off the ground)."""
        return self.armed and not self.on_ground

    @property
    def landed_state(self) -> int:
        return landed_state(self.started, self.on_ground, self.mode == TAKEOFF, self.active.landing)

    @property
    def setpoints_clamped(self) -> int:
        return self.offboard.clamped

    @property
    def attitude_setpoint(self) -> AttitudeTarget | None:
        """Offboard attitude flying: the set-point for the attitude loop (the velocity controller out of the loop)."""
        return self.offboard.attitude if self.mode == OFFBOARD and self.flying else None

    @property
    def active(self) -> FlightMode:
        return self.modes[self.mode]

    @property
    def mode_id(self) -> ModeId:
        return self.active.id

    @property
    def home(self) -> HomePosition:
        return self.homes.position

    def switch_mode(self, mode: str, state: VehicleState, reason: str | None = None) -> None:
        """Enter `mode` (again, if it is the current one: it starts afresh, unless it goes on when re-entered)."""
        target = self.modes[mode]
        target.entered_from(self.active)
        if mode != self.mode or target.restarts_when_reentered:
            target.activate(state)
        if target.resets_land_detector:
            self.land_detector.reset()
        if mode != self.mode:
            self.mode = mode
            self.state_version += 1
            if reason:
                self.say(mavlink.MAV_SEVERITY_INFO, reason)

    def terminate_flight(self, text: str) -> None:
        """Flight termination: the motors stop (a forced disarm, PWM to the disarmed values: in the air the vehicle
        falls) and stay stopped until `clear_termination`."""
        self.terminated = True
        self.state_version += 1
        if self.armed:
            self._set_armed(False, text, mavlink.MAV_SEVERITY_CRITICAL)
        else:
            self.say(mavlink.MAV_SEVERITY_CRITICAL, text)

    def clear_termination(self) -> None:
        """The vehicle may arm again after a flight termination."""
        if self.terminated:
            self.terminated = False
            self.state_version += 1
            self.say(mavlink.MAV_SEVERITY_INFO, "Flight termination cleared")

    def set_region_of_interest(self, roi: RegionOfInterest | None) -> None:
        """DO_SET_ROI_*: the vehicle's region of interest (the mission keeps it), turned to at once by the modes
        flying the mission's items (Mission, Return's mission landing)."""
        self.navigator.point_at(roi, self.active.flies_mission)

    def set_home(self, home: HomePosition) -> None:
        """DO_SET_HOME: Return and the geofence's distances use `home` from now."""
        self.homes.set(home)

    def reposition(self, state: VehicleState, position: np.ndarray, speed: float | None, yaw: float | None) -> None:
        """Go-to: Hold flies to `position` and holds there (Hold must be active)."""
        self.navigator.reposition(state, position, speed, yaw)

    def orbit(self, state: VehicleState, circle: Circle) -> None:
        """Orbit circles `circle` (Orbit must be active)."""
        self.navigator.orbit_around(state, circle)

    def transition(self, target: int, state: VehicleState) -> str | None:
        """A VTOL transition in Hold; what to say (None: already there)."""
        return self.navigator.transition(target, state)

    def set_cruise_speed(self, speed: float | None) -> None:
        self.navigator.set_cruise_speed(speed)

    def drive_output(self, motor: bool, index: int, value: float | None, timeout_s: float) -> None:
        """A motor or servo test of a disarmed vehicle (output_tests.py), from now for `timeout_s`."""
        self.output_tests.drive(motor, index, value, timeout_s, self.now_usec)

    def outputs_on_ground(self, disarmed_pwm: list[int], now_usec: int) -> list[int]:
        """The PWM of a disarmed vehicle: `disarmed_pwm` with the output tests running applied."""
        return self.output_tests.applied(disarmed_pwm, now_usec)

    def failure_known(self, failure: Failure) -> None:
        """A failure the plant applied is known (the failsafes watch the sensors')."""
        self.failsafe.failure_known(failure)

    def gcs_heartbeat(self) -> None:
        """A ground station's HEARTBEAT (the data-link failsafe)."""
        self.failsafe.gcs_heartbeat(self.now_usec)

    def check_mission(self) -> None:
        """A new mission or fence: checked against the geofence at once, as PX4's navigator does."""
        self.feasibility.check()

    def _set_armed(self, armed: bool, text: str, severity: int = mavlink.MAV_SEVERITY_INFO) -> None:
        self.armed = armed
        self.state_version += 1
        if armed:
            self.output_tests.clear()  # PX4 ends the tests when the vehicle arms
            self.ground.armed(self.now_usec)
        else:
            self.ground.disarmed()
        self.say(severity, text)

    def start(self, state: VehicleState) -> None:
        """The first valid state: a vehicle spawned in the air holds where it is."""
        self.started = True
        self.now_usec = self._start_usec = state.time_usec
        if self.on_ground:
            self.homes.set_here(state.position_ned)  # PX4: home at the first valid position on the ground
        if self.flying and self.profile is None:
            self.navigator.hold.activate(state)
        if self.armed:
            self.ground.armed(state.time_usec)

    def restart(self, state: VehicleState) -> None:
        """The plant's clock went back (a new plant run): time-stamped things start afresh."""
        self.now_usec = self._start_usec = state.time_usec
        self.offboard.restart()
        self.manual.restart()
        self.failsafe.restart()
        self.battery.restart()
        self.ground.restarted(state.time_usec, self.armed)
        if self.profile is None and self.flying:
            self.navigator.hold.activate(state)

    def refusal(self, name: str | None = None, positional: bool = False) -> Reply | None:
        """Commands are off while the internal --profile flies; `name` needs a vehicle state first, and a
        `positional` one a position estimate (PX4: the mode cannot run)."""
        if self.profile is not None:
            return TEMPORARILY_REJECTED, "flying the internal --profile: flight commands are off"
        if name is not None and not self.started:
            return TEMPORARILY_REJECTED, f"{name} denied: no vehicle state from the plant yet"
        if name is not None and positional and self.failsafe.position_lost:
            return TEMPORARILY_REJECTED, f"{name} denied: no position estimate (GPS lost)"
        return None

    # ---- requests (commands) ---------------------------------------------------------------------------------
    def arm(self, state: VehicleState, force: bool = False) -> Reply:
        if (refusal := self.refusal()) is not None:
            return refusal
        if self.armed:
            return ACCEPTED, None
        if not self.started or not state.valid:
            return TEMPORARILY_REJECTED, "Arming denied: no vehicle state from the plant yet"
        why = prearm_refusal(
            state,
            force=force,
            terminated=self.terminated,
            outside_fence=None if force else self.failsafe.outside_fence(state.position_ned),
            mission_invalid=not force and self.mode == MISSION and self.feasibility.check() is not None,
            mode_prevents_arming=self.active.prevents_arming,
        )
        if why is not None:
            return DENIED, why
        self._set_armed(True, "Armed")
        if not self.failsafe.position_lost:
            self.homes.set_here(state.position_ned)  # PX4: home where the vehicle arms (not over a manual home)
        if self.mode == MISSION:
            self.active.activate(state)  # a takeoff item first: the mission takes off
        if self.mode == OFFBOARD and not self._offboard_fresh():
            self.switch_mode(HOLD, state)
        return ACCEPTED, None

    def disarm(self, state: VehicleState, force: bool = False) -> Reply:
        if (refusal := self.refusal()) is not None:
            return refusal
        if not self.armed:
            return ACCEPTED, None
        if not self.on_ground and not force:
            return DENIED, f"Disarming denied: in the air (param2 = {FORCE_MAGIC} forces it)"
        self._set_armed(False, "Disarmed" + (" in the air (forced)" if not self.on_ground else ""))
        return ACCEPTED, None

    def _offboard_fresh(self) -> bool:
        return self.offboard.fresh(self.now_usec, self.params["COM_OF_LOSS_T"])

    def set_mode(self, mode: str, state: VehicleState) -> Reply:
        """A ground station chooses `mode`: the commander's checks, then the mode's own entry rules."""
        if (refusal := self.refusal(mode)) is not None:
            return refusal
        if mode == self.mode:
            return ACCEPTED, None
        target = self.modes[mode]
        if (refusal := self.refusal(mode, positional=target.needs_position)) is not None:
            return refusal
        if (refusal := target.entry_refusal(ModeEntry(self.now_usec, self.flying))) is not None:
            return refusal
        if mode == TAKEOFF:
            return self.takeoff(state, None)
        self.switch_mode(mode, state)
        return ACCEPTED, None

    def start_mission(self, state: VehicleState) -> Reply:
        """MAV_CMD_MISSION_START: Mission mode, if the mission passes the feasibility check (PX4: DENIED if not)."""
        if self.navigator.mission.stored and self.mode != MISSION and self.feasibility.check() is not None:
            return DENIED, "Mission start denied! No valid mission"
        return self.set_mode(MISSION, state)

    def manual_control(self, sticks: ManualControlInput) -> Reply:
        """MANUAL_CONTROL as a virtual RC, when COM_RC_IN_MODE takes it."""
        return self.manual.receive(sticks, self.now_usec)

    def follow_target(self, report: FollowTargetReport) -> Reply:
        """FOLLOW_TARGET: the Follow Me target's estimate takes it in any mode (PX4's estimator always runs)."""
        self.target.measure(report.position, report.velocity, self.now_usec)
        return ACCEPTED, None

    def takeoff(self, state: VehicleState, altitude_above_home: float | None) -> Reply:
        """Climb to `altitude_above_home` (None: MIS_TAKEOFF_ALT) over the current position, then Hold."""
        if (refusal := self.refusal("Takeoff", positional=True)) is not None:
            return refusal
        if altitude_above_home is None:
            altitude_above_home = self.params["MIS_TAKEOFF_ALT"]
        elif not 1.0 <= altitude_above_home <= 1000.0:
            return DENIED, f"Takeoff denied: altitude {altitude_above_home:.1f} m above home not in 1..1000 m"
        self.navigator.takeoff.start(state, self.homes.position.down - altitude_above_home)
        if self.mode != TAKEOFF:
            self.mode = TAKEOFF
            self.state_version += 1
        if self.armed and self.on_ground:
            self._lift_off()
        if not self.armed:
            self.say(mavlink.MAV_SEVERITY_INFO, f"Takeoff to {altitude_above_home:.1f} m: waiting for arming")
        else:
            self.say(mavlink.MAV_SEVERITY_INFO, f"Takeoff to {altitude_above_home:.1f} m")
        return ACCEPTED, None

    def setpoints_cover(self, time_usec: int) -> bool:
        """--offboard-lockstep: the client's set-points reach this simulation time (True without the option)."""
        return self.offboard.covers(time_usec)

    # ---- 100 Hz -------------------------------------------------------------------------------------------------
    def _lift_off(self) -> None:
        self.ground.lift_off()
        self.state_version += 1

    def tick(self, state: VehicleState, time_usec: int, mean_thrust_fraction: float) -> np.ndarray | None:
        """Mode logic at 100 Hz; the velocity set-point while flying (None on the ground), and the yaw reference."""
        setpoint = self._mode_tick(state, time_usec, mean_thrust_fraction)
        yaw = None if setpoint is None or self.profile is not None else self.active.yaw(state)
        if yaw is not None and not multicopter_speed(setpoint, self.params["MPC_XY_VEL_MAX"]):
            yaw = None  # forward flight: the nose follows the course
        self.yaw_shaper.update(yaw, float(state.euler[2]), math.radians(self.params["MPC_YAWRAUTO_MAX"]), TICK_S)
        return setpoint

    def _mode_tick(self, state: VehicleState, time_usec: int, mean_thrust_fraction: float) -> np.ndarray | None:
        self.now_usec = time_usec
        self.offboard.take_due(time_usec)
        battery = self.battery.update(time_usec, self.armed)
        if self.profile is not None:
            return self.profile((time_usec - self._start_usec) / 1e6) if self.flying else None
        manual_lost = self.mode in (POSITION, ALTITUDE) and not self.manual.fresh(time_usec)
        decision = self.failsafe.check(FailsafeInputs(time_usec, self.flying, self.mode, state.position_ned,
                                                      self.mode == OFFBOARD and not self._offboard_fresh(),
                                                      manual_lost, self.mode == OFFBOARD
                                                      and self.manual.refusal(POSITION, time_usec) is None,
                                                      self.armed, battery.warning))  # fmt: skip
        if decision is not None:
            self._failsafe(decision, state)
        if not self.armed:
            at_rest = float(np.linalg.norm(state.velocity_ned)) < HOME_AT_REST_SPEED  # not falling after a termination
            if self.on_ground and at_rest and not self.failsafe.position_lost:
                self.homes.follow(state.position_ned)
            return None
        if self.on_ground:
            return self._on_ground(state, time_usec)
        if self.mode == TAKEOFF:
            takeoff = self.navigator.takeoff
            if not takeoff.done(state):
                return takeoff.setpoint(state)
            self.switch_mode(HOLD, state, "Takeoff complete: Hold")
            self.navigator.hold.hold_at(*takeoff.end)
        mode = self.active
        setpoint = mode.setpoint(state)
        if mode.detects_landing and self.land_detector.update(state, mean_thrust_fraction, time_usec,
                                                              float(setpoint[2])):  # fmt: skip
            self.ground.touch_down(time_usec)
            self.state_version += 1
            self.say(mavlink.MAV_SEVERITY_INFO, "Landing detected")
            mode.touched_down(state)
            return None
        if not mode.detects_landing:
            self.land_detector.reset()
        return setpoint

    def _failsafe(self, decision: Decision, state: VehicleState) -> None:
        """A failsafe's action, as failsafe_reaction.py plans it."""
        self.failsafes += 1
        plan = reaction(decision, self.mode, self.flying)
        for severity, text in plan.before:
            self.say(severity, text)
        if plan.cut_motors is not None and plan.terminate:
            self.terminate_flight(plan.cut_motors)
        elif plan.cut_motors is not None:
            self._set_armed(False, plan.cut_motors)
        if plan.mode is not None:
            self.switch_mode(plan.mode, state, plan.mode_reason)
            if plan.descend:
                self.navigator.land.descend = True
        for severity, text in plan.after:
            self.say(severity, text)

    def _on_ground(self, state: VehicleState, time_usec: int) -> np.ndarray | None:
        if (why := self.ground.disarm_due(self.params, time_usec)) is not None:
            self._set_armed(False, why)
            return None
        if self.active.lifts_off(state):
            self._lift_off()
            return self.active.setpoint(state)
        return None


def build_commander(params: ParameterStore, hover_fraction: float, *, armed: bool, in_air: bool,
                    say: Callable[..., None] = lambda severity, text, key=None: None,
                    profile: Callable[[float], np.ndarray] | None = None, stamped_setpoints: bool = False,
                    missions: MissionStore | None = None, home: Home = Home()) -> Commander:  # fmt: skip
    """A commander with its collaborators: home (at `home` until set), the ground state (`in_air`), the failsafes,
    the navigator and its modes on `missions`; `armed`: spawned armed; `profile`: the internal set-points flown from
    the start; `stamped_setpoints`: --offboard-lockstep."""
    missions = missions if missions is not None else MissionStore()
    homes = HomeKeeper(home)
    ground = GroundState(in_air)
    failsafe = Failsafe(params, missions, homes, say)
    navigator = build_navigator(params, missions, homes, hover_fraction, failsafe.outside_fence,
                                landed=lambda: ground.on_ground, say=say, stamped_setpoints=stamped_setpoints)  # fmt: skip
    return Commander(params, navigator, failsafe, homes, ground, LandDetector(hover_fraction),
                     BatterySimulator(params), armed=armed, say=say, profile=profile)  # fmt: skip
