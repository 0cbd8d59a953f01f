"""The survey missions of issue 11 through `vtol mission` (docs/missions.md): takeoff, 6 waypoints
400 m apart at 25 m/s (DO_CHANGE_SPEED), back over home, land. The unified MPC flies missions/survey.plan (no
DO_VTOL_TRANSITION: it transitions when the legs ask for cruise speed); the PID flies
missions/survey_transitions.plan, whose DO_VTOL_TRANSITION items drive its phases. Lockstep, uploaded through
the MAVLink mission protocol; every waypoint within its acceptance radius, the landing within 2 m of home, the
figures written. Bad files are refused in one line."""

from __future__ import annotations

import json
from pathlib import Path

from ground_tools.cli import main
from ground_tools.mission_command import FIGURE_FILES
from tests.sitl.test_failure_detection import FALSE_ALARM
from tests.unit.test_survey_mission import MISSIONS


def fly(plan: str, controller: str, out: Path) -> dict:
    assert main(["mission", str(MISSIONS / plan), "--controller", controller, "--out", str(out)]) == 0
    folder = out / Path(plan).stem
    result = json.loads((folder / controller / "result.json").read_text())
    print(json.dumps(result))
    assert len(result["waypoints"]) == 7  # the six survey waypoints and the return over home
    for waypoint in result["waypoints"]:
        assert waypoint["closest_m"] <= waypoint["acceptance_m"], waypoint
    assert result["landing_error_m"] <= 2.0
    autopilot = folder / controller / "vehicle" / "vehicle-1" / "vtol-autopilot.stderr"
    assert not FALSE_ALARM.search(autopilot.read_text())  # the actuator checks raise no false alarm on the survey
    for name in FIGURE_FILES:
        assert (folder / name).stat().st_size > 10_000
    return result


def modes(out: Path, plan: str, controller: str) -> list[str]:
    lines = (out / Path(plan).stem / controller / "flight.csv").read_text().splitlines()
    return [line.rsplit(",", 1)[1] for line in lines[1:]]


def test_the_mpc_flies_the_survey_without_transition_items(tmp_path):
    fly("survey.plan", "mpc", tmp_path)


def test_the_pid_flies_the_survey_with_transition_items_driving_its_phases(tmp_path):
    fly("survey_transitions.plan", "pid", tmp_path)
    phases = modes(tmp_path, "survey_transitions.plan", "pid")
    assert "FW" in phases and phases[-1] == "MC"  # forward flight on the legs, multicopter for the landing
