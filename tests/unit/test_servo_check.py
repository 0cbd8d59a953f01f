"""The tilt servo check (autopilot/commander/servo_check.py) on moments the aircraft model itself gives: the body
turns as the true tilts make it turn, the check knows only the estimated ones."""

from __future__ import annotations

import math

import pytest

from aircraft.airframe import load_airframe
from aircraft.failures import Failure, FailureType, FailureUnit, failed_actuators
from autopilot.commander.servo_check import MomentModel, ServoCheck, ServoJamDetector, TiltFit, failing_servo
from autopilot.plant_loop import surfaces_failed

AIRFRAME = load_airframe(None)
MODEL = MomentModel(AIRFRAME)
CHECK = ServoCheck(min_moment=0.15, min_angle_rad=math.radians(2.0), timeout_usec=50_000)
REPORT_USEC = 10_000  # the ESC reports' 100 Hz
HOVER_THRUSTS = [18.2] * 4  # N, about the weight over four rotors


def fly(true_tilts: list[float], estimated: list[float], thrusts: list[float] | None = None,
        true_thrusts: list[float] | None = None, reports: int = 10, airspeed: float = 0.0,
        detector: ServoJamDetector | None = None) -> list:  # fmt: skip
    """`reports` ESC reports of a body turned by the rotors at `true_tilts` and `true_thrusts` while the check is
    given `estimated` and `thrusts`; what the check said at each."""
    thrusts = thrusts or HOVER_THRUSTS
    true_thrusts = true_thrusts or thrusts
    detector = detector or ServoJamDetector(MODEL)
    inertia, rates, said = MODEL.inertia, [0.0, 0.0, 0.0], []
    for report in range(reports):
        said.append(detector.sample(report * REPORT_USEC, rates, thrusts, estimated, [0.0] * 4, airspeed, [0, 1, 2, 3],
                                    CHECK))  # fmt: skip
        moment = MODEL.moment(true_thrusts, true_tilts, [0.0] * 4, airspeed, rates)
        gyroscopic = MODEL.gyroscopic(rates, [0.0, 0.0, 0.0])
        rates = [w + REPORT_USEC * 1e-6 * (m - g) / j for w, m, g, j in zip(rates, moment, gyroscopic, inertia)]
    return said


def test_tilts_as_estimated_leave_nothing_unexplained_and_nothing_is_found():
    tilts = [math.radians(40.0)] * 4
    detector = ServoJamDetector(MODEL)
    assert fly(tilts, tilts, detector=detector) == [None] * 10
    assert detector.last_unexplained < 1e-6
    assert detector.jammed == []


@pytest.mark.parametrize("servo", [0, 1, 2, 3])
def test_a_servo_off_its_estimate_is_found_at_its_true_tilt_once_failing_for_the_timeout(servo):
    estimated = [math.radians(10.0)] * 4
    true = list(estimated)
    true[servo] = math.radians(25.0)
    said = fly(true, estimated)
    # the first report only primes the check; failing from the second on (10 ms), 50 ms later it is a jam
    assert said[:6] == [None] * 6
    jam = said[6]
    assert jam is not None and jam.servo == servo and jam.first
    assert math.degrees(jam.tilt_rad) == pytest.approx(25.0, abs=0.1)


def test_a_jam_found_again_is_not_the_first():
    estimated, true = [0.0] * 4, [math.radians(20.0), 0.0, 0.0, 0.0]
    detector = ServoJamDetector(MODEL)
    said = [jam for jam in fly(true, estimated, reports=20, detector=detector) if jam is not None]
    assert [jam.first for jam in said] == [True, False, False]  # every 50 ms while the estimate stays put
    assert detector.jammed == [0]
    detector.free(0)  # it followed its command again: a new finding is a new jam
    assert detector.jammed == []
    assert [jam.first for jam in fly(true, estimated, detector=detector) if jam is not None] == [True]


def test_a_jammed_servo_moving_on_behind_a_slow_rotor_is_found_again_not_blamed_on_the_servo_beside_it():
    # Late in the transition (the servo map, jammed at 25 m/s): servo 1 found jammed at 70 deg slews on towards
    # where it jams while its rotor turns too slowly to be judged on its own; servo 3's rotor, on the same side,
    # explains the moment almost as well and must not be found jammed instead.
    estimated = [math.radians(a) for a in (70.0, 90.0, 90.0, 90.0)]
    true = [math.radians(55.0), *estimated[1:]]
    thrusts = [1.7, 11.8, 10.3, 2.9]
    detector = ServoJamDetector(MODEL, jammed=[0])
    said = [jam for jam in fly(true, estimated, thrusts=thrusts, airspeed=25.0, detector=detector) if jam is not None]
    assert said, "the moving servo is found again"
    assert {jam.servo for jam in said} == {0}
    assert math.degrees(said[0].tilt_rad) == pytest.approx(55.0, abs=1.0)
    assert not said[0].first and detector.jammed == [0]


def test_a_tilt_within_the_angle_threshold_is_not_failing():
    estimated, true = [0.0] * 4, [math.radians(1.5), 0.0, 0.0, 0.0]
    assert fly(true, estimated) == [None] * 10


def test_a_rotor_giving_less_thrust_than_its_rpm_says_is_not_a_jam():
    tilts = [math.radians(30.0)] * 4
    assert fly(tilts, tilts, true_thrusts=[9.0, 18.2, 18.2, 18.2]) == [None] * 10


def test_a_moment_two_servos_explain_alike_singles_out_neither():
    fits = [TiltFit(0, 0.3, 0.010, 1.0), TiltFit(3, 0.3, 0.015, 1.0)]
    assert failing_servo(fits, 1.0, [0.0] * 4, CHECK) is None
    assert failing_servo(fits[:1] + [TiltFit(3, 0.3, 0.5, 1.0)], 1.0, [0.0] * 4, CHECK) == fits[0]


def test_a_pause_forgets_the_last_report_and_what_was_failing():
    estimated, true = [0.0] * 4, [math.radians(20.0), 0.0, 0.0, 0.0]
    detector = ServoJamDetector(MODEL)
    fly(true, estimated, reports=5, detector=detector)  # failing, not yet for the timeout
    detector.pause()
    assert fly(true, estimated, reports=6, detector=detector) == [None] * 6  # primed again, then 50 ms anew
    detector.reset()
    assert detector.jammed == []


def test_the_check_pauses_while_a_surface_is_known_failed_and_not_once_it_is_cleared():
    elevator_stuck = Failure(FailureUnit.SERVO, FailureType.STUCK, 7, 5.0)
    assert not surfaces_failed([Failure(FailureUnit.SERVO, FailureType.STUCK, 1, 60.0)])  # a tilt servo
    assert surfaces_failed([elevator_stuck])
    assert not surfaces_failed([elevator_stuck, Failure(FailureUnit.SERVO, FailureType.OK, 7)])
    assert surfaces_failed([Failure(FailureUnit.SERVO, FailureType.OFF, 0)])
    assert not surfaces_failed(
        [Failure(FailureUnit.SERVO, FailureType.OFF, 0), Failure(FailureUnit.SERVO, FailureType.OK, 0)]
    )


def test_failed_actuators_follow_the_failures_in_order_and_ok_clears_what_it_addresses():
    motor_1_off, all_motors_ok = (
        Failure(FailureUnit.MOTOR, FailureType.OFF, 1),
        Failure(FailureUnit.MOTOR, FailureType.OK, 0),
    )
    assert failed_actuators([motor_1_off]) == {0}
    assert failed_actuators([motor_1_off, all_motors_ok]) == set()
    assert failed_actuators([Failure(FailureUnit.SERVO, FailureType.STUCK, 2, 30.0), motor_1_off]) == {5, 0}
    assert failed_actuators([Failure(FailureUnit.GYRO, FailureType.OFF, 0)]) == set()  # a sensor is no actuator
