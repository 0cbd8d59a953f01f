"""The generated reference pages (ground_tools/reference.py): what they are made of, and that the committed ones
are what the code gives (the commands page, which runs each program's --help, is checked by .ci/run)."""

from __future__ import annotations

from pathlib import Path

import pytest

from autopilot.storage.parameters import DEFINITIONS, INT32, REAL32, ParameterDefinition
from ground_tools import reference
from transport.mavlink import mavlink as M
from transport.telemetry import KEY_EXPRESSIONS, PLANT_STATE_FIELDS

ROOT = Path(__file__).resolve().parents[2]


def test_the_parameter_page_has_a_row_per_parameter_with_px4s_default_where_it_differs():
    ours = ParameterDefinition("VT_EXAMPLE", INT32, 1, 0, 2, "", "an example | with a bar", px4=False)
    same = ParameterDefinition("MPC_EXAMPLE", REAL32, 2.5, 0.5, 10, "m/s", "the same as PX4's")
    differs = ParameterDefinition("NAV_EXAMPLE", REAL32, 250, 100, 2000, "m", "radius", px4_default=80)
    page = reference.parameters_page((ours, same, differs))
    assert "| `VT_EXAMPLE` | INT32 | 1 | 0 … 2 |  | ours | an example \\| with a bar |" in page
    assert "| `MPC_EXAMPLE` | REAL32 | 2.5 | 0.5 … 10 | m/s | same default | the same as PX4's |" in page
    assert "| `NAV_EXAMPLE` | REAL32 | 250 | 100 … 2000 | m | default 80 | radius |" in page


def test_the_mavlink_tables_are_the_services_dispatch_tables():
    tables = reference.mavlink_tables()
    assert {"HEARTBEAT", "COMMAND_LONG", "PARAM_SET", "MISSION_ITEM_INT", "SET_POSITION_TARGET_LOCAL_NED"} <= set(
        tables.messages
    )
    assert {M.MAV_CMD_COMPONENT_ARM_DISARM, M.MAV_CMD_DO_SET_MODE, M.MAV_CMD_INJECT_FAILURE} <= set(tables.commands)
    assert [mode.name for mode in tables.modes][:3] == ["Hold", "Takeoff", "Land"]
    assert all(summary and not summary.startswith("AUTO.") for summary in tables.mode_summaries)
    page = reference.mavlink_page(tables)
    assert "| MAV_CMD_COMPONENT_ARM_DISARM | 400 |" in page
    assert "| Hold | AUTO.LOITER | 4 / 3 | 50593792 |" in page


def test_the_zenoh_page_lists_every_key_with_its_payload():
    page = reference.zenoh_page(KEY_EXPRESSIONS, PLANT_STATE_FIELDS)
    assert "| `vtol/<sysid>/plant/state` |" in page
    assert "| `vtol/<sysid>/autopilot/mpc` |" in page
    assert "`cmd_rudder`." in page


@pytest.mark.parametrize(
    ("usage", "expected"),
    [
        ("usage: vtol [-h] {fly,scenario,up} ...\n", ["fly", "scenario", "up"]),
        (
            "usage: vtol [-h] COMMAND ...\n\npositional arguments:\n  COMMAND\n    fly       fly a profile\n"
            "              and plot it\n    up        start it\n\noptions:\n",
            ["fly", "up"],
        ),
        ("usage: vtol-sim [-h]\n", []),
        ("usage: vtol-autopilot [-h] [--controller {pid,mpc}] [--quiet]\n", []),
    ],
)
def test_subcommands_come_from_the_usage_line(usage, expected):
    assert reference.subcommands(usage) == expected


def test_the_first_sentence_and_the_mode_summary():
    assert reference.first_sentence("Set a value.  More words.") == "Set a value."
    assert reference.first_sentence("No full stop here") == "No full stop here"
    assert reference.mode_summary("AUTO.LOITER: brake and hold. More.") == "brake and hold."
    assert reference.mode_summary("POSCTL.ORBIT (PX4's Orbit): circle a centre.") == "circle a centre."


def test_a_missing_or_different_page_is_stale(tmp_path):
    (tmp_path / "a.md").write_text("current\n")
    (tmp_path / "b.md").write_text("old\n")
    expected = {Path("a.md"): "current\n", Path("b.md"): "new\n", Path("c.md"): "new\n"}
    assert reference.stale(expected, tmp_path) == [Path("b.md"), Path("c.md")]


def test_the_committed_tables_are_what_the_code_gives():
    """After changing a parameter, a mode, a handler, a command, a mission item, a stream or a zenoh key:
    `python -m ground_tools.reference` rewrites the pages."""
    expected = {
        "parameters.md": reference.parameters_page(DEFINITIONS),
        "mavlink.md": reference.mavlink_page(reference.mavlink_tables()),
        "zenoh.md": reference.zenoh_page(KEY_EXPRESSIONS, PLANT_STATE_FIELDS),
    }
    for name, text in expected.items():
        assert (ROOT / reference.REFERENCE_FOLDER / name).read_text() == text, f"docs/reference/{name} is out of date"
