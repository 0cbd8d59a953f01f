"""`vtol scenario` (issue 6): the stamped-set-point lockstep, the scripted ground station, run folders, metrics,
determinism, recordings, and the pure pieces (triggers, grid, acceptance) checked by hand."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from autopilot.navigator.stamped_setpoints import StampedSetpoints
from autopilot.topics.yaw_setpoint import YawSetpoint
from ground_tools.exit_status import CHECK_FAILED, FAILED, OK
from ground_tools.lockstep_client import PERIOD_MS, START_MS, grid_stamp, setpoint_for, tilt_commands_deg, yaw_turns
from ground_tools.scenario_command import checked, exit_status
from ground_tools.scenario_report import acceptance, velocity_rmse
from scenarios.experiments import BANK_THEORY_DEG, SCENARIOS, Telemetry, servo_reaches, yaw_reaches
from scenarios.profiles import PROFILES, accel_decel_braking_at
from transport.mavlink import mavlink

pytestmark = pytest.mark.timeout(600)


# ---- pure pieces ------------------------------------------------------------------------------------------------
def test_stamped_setpoints_take_effect_at_their_stamp_whatever_the_arrival_order() -> None:
    stamped = StampedSetpoints()
    assert not stamped.covers(0)
    stamped.add(40, (np.array([2.0, 0, 0]), None))
    stamped.add(20, (np.array([1.0, 0, 0]), YawSetpoint(heading=0.5)))
    assert stamped.covers(40_999) and not stamped.covers(41_000)  # whole milliseconds, like time_boot_ms
    assert stamped.due(19_999) is None
    velocity, yaw = stamped.due(20_000)
    assert velocity[0] == 1.0 and yaw == YawSetpoint(heading=0.5)  # the yaw set-point goes with its velocity
    assert stamped.due(30_000) is None  # nothing new due: the last one goes on
    stamped.add(40, (np.array([3.0, 0, 0]), None))  # same stamp again: the later one wins
    assert stamped.due(100_000)[0][0] == 3.0
    stamped.clear()
    assert not stamped.covers(0)


def test_grid_and_profile_setpoints() -> None:
    assert [grid_stamp(t) for t in (0, 1, 20, 22, 39, 40)] == [0, 20, 20, 40, 40, 40]
    accel = SCENARIOS["accel"]
    assert np.array_equal(setpoint_for(accel, START_MS - PERIOD_MS), np.zeros(3))  # hover before the profile
    assert setpoint_for(accel, START_MS + 5000)[0] == pytest.approx(10.0)  # 2 m/s^2 x 5 s
    assert setpoint_for(accel, START_MS + 20000)[0] == pytest.approx(27.74)


def test_accel_decel_with_another_braking_rate() -> None:
    paper, gentle = PROFILES["accel-decel"][0], accel_decel_braking_at(1.0)
    for t in (0.0, 7.5, 15.0, 15.5, 20.0, 31.0):
        assert np.array_equal(accel_decel_braking_at(2.0)(t), paper(t))
    assert np.array_equal(gentle(10.0), paper(10.0))  # the same acceleration and cruise
    assert gentle(21.0)[0] == pytest.approx(18.0) and paper(21.0)[0] == pytest.approx(12.0)
    assert gentle(40.0)[0] == 0.0


def test_triggers() -> None:
    servo = servo_reaches(1, 60.0)
    assert not servo(Telemetry(tilt_cmd_deg=(59.9, 80.0, 80.0, 80.0)))
    assert servo(Telemetry(tilt_cmd_deg=(60.0, 0.0, 0.0, 0.0)))
    yaw = yaw_reaches(90.0)
    assert [yaw(Telemetry(yaw_unwrapped_deg=y)) for y in (0.0, 89.9, 90.0, 179.0, 190.0, -89.0)] == \
        [False, False, True, True, True, False]  # fmt: skip
    late = yaw_reaches(240.0)  # two thirds of a right-hand turn: not at the start, where the wrapped yaw is 0
    assert [late(Telemetry(yaw_unwrapped_deg=y)) for y in (0.0, 120.0, 239.9, 240.0)] == [False, False, False, True]
    turns = 0
    for previous, now in ((0.0, 90.0), (90.0, 179.0), (179.0, -179.0), (-179.0, -120.0), (-120.0, 178.0)):
        turns += yaw_turns(previous, now)
    assert turns == 0  # round to the right past 180 deg, then back to the left across it
    assert yaw_turns(179.0, -179.0) == 1 and yaw_turns(-179.0, 179.0) == -1


def test_servo_output_raw_to_tilt(airframe) -> None:
    message = mavlink.MAVLink_servo_output_raw_message(0, 0, *([1000] * 4), 2000, 1000, 1500, 1500, *([1500] * 8))
    tilts = tilt_commands_deg(airframe, message)
    assert tilts[0] == pytest.approx(math.degrees(airframe.tilt_max))
    assert tilts[1] == pytest.approx(math.degrees(airframe.tilt_min))


def test_acceptance_checks_by_hand() -> None:
    base = {"survived": True, "vx_rmse": 0.3, "vy_rmse": 0.4, "vz_rmse": 0.0}
    assert velocity_rmse(base) == pytest.approx(0.5)
    circle = {**base, "radial_rmse_m": 4.9, "bank_mean_deg": BANK_THEORY_DEG + 2.9}
    pid = {**base, "vx_rmse": 1.0}
    assert all(passed for _, passed in acceptance("circle", circle, pid))
    bad = acceptance("circle", {**circle, "radial_rmse_m": 5.1, "bank_mean_deg": BANK_THEORY_DEG - 3.1}, pid)
    assert [passed for _, passed in bad] == [True, True, False, False, True]
    # a PID that crashed is not a bar to beat
    assert len(acceptance("accel", base, {**pid, "survived": False})) == 2
    assert not acceptance("accel-decel", {**base, "final_speed": 0.6}, None)[2][1]
    # the nose across the course (a skid), and a run that never moved (no course: nothing to check)
    assert [passed for _, passed in acceptance("accel", {**base, "heading_error_max_deg": 20.1}, None)] == [True, False]
    assert acceptance("accel", {**base, "heading_error_max_deg": None}, None)[1][1]


def test_a_failed_acceptance_check_is_exit_status_3_and_a_failed_run_1(tmp_path, capsys) -> None:
    base = {"survived": True, "vx_rmse": 0.3, "vy_rmse": 0.4, "vz_rmse": 0.0, "heading_error_max_deg": 20.1}
    (tmp_path / "accel" / "mpc").mkdir(parents=True)
    (tmp_path / "accel" / "mpc" / "metrics.json").write_text(json.dumps(base))
    failed = checked(tmp_path, "accel")
    assert failed == ["accel: nose on the course (heading off it <= 20 deg)"]
    assert "vtol: accel: MPC nose on the course (heading off it <= 20 deg): FAIL" in capsys.readouterr().out
    assert exit_status([], failed) == CHECK_FAILED == 3
    assert "vtol: error: 1 acceptance check(s) failed: accel: nose on the course" in capsys.readouterr().err
    assert exit_status(["accel/pid"], failed) == FAILED == 1
    assert exit_status([], []) == OK == 0
    assert checked(tmp_path, "circle") == []  # not flown: nothing to check


def test_course_rate_of_the_circle_setpoint_is_its_angular_rate() -> None:
    from autopilot.control.velocity_command import course_rate

    omega = 26.0 / 250.0
    for angle in (0.0, 1.0, 3.0):  # v = 26 (cos wt, sin wt): dv/dt = omega x v
        v_sp = 26.0 * np.array([math.cos(angle), math.sin(angle), 0.0])
        rate = 26.0 * omega * np.array([-math.sin(angle), math.cos(angle), 0.0])
        assert course_rate(v_sp, rate) == pytest.approx(omega)
    assert course_rate(np.array([1.0, 0.0, 0.0]), np.array([0.0, 5.0, 0.0])) == 0.0  # too slow to have a course
