"""Airframe files: the default loads, every kind of broken file is refused with one line (and exit 2 on the CLI)."""

from __future__ import annotations

import pytest

from tests.conftest import vtol_sim_command
from tests.unit.test_airframe import BROKEN
from tiltrotor_sitl._children import run_to_end


@pytest.mark.parametrize("case", ["not toml", "negative mass"])
def test_vtol_sim_refuses_a_broken_airframe_with_one_line_and_exit_2(tmp_path, case):
    path = tmp_path / "broken.toml"
    path.write_text(BROKEN[case][0])
    result = run_to_end(vtol_sim_command("--airframe", str(path), "--no-zenoh"), timeout_s=60)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("vtol-sim: error:") and BROKEN[case][1] in lines[0]
