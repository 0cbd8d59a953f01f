"""The command lines' conventions (vtol, vtol-sim, vtol-autopilot): --version everywhere, help on every option, one
metavar style (each value named, I an instance, P a port), and each vtol command's --help saying its exit
statuses."""

from __future__ import annotations

import argparse

import pytest

from autopilot.cli import build_parser as autopilot_parser
from ground_tools.cli import parser as vtol_parser
from sim_bridge.cli import build_parser as sim_parser
from transport.cli import package_version


def commands() -> dict[str, argparse.ArgumentParser]:
    """Every parser: vtol, each `vtol COMMAND`, vtol-sim, vtol-autopilot."""
    vtol = vtol_parser()
    found = {"vtol": vtol, "vtol-sim": sim_parser(), "vtol-autopilot": autopilot_parser()}
    for action in vtol._actions:
        if isinstance(action, argparse._SubParsersAction):
            found.update({f"vtol {name}": sub for name, sub in action.choices.items()})
    return found


COMMANDS = commands()


@pytest.mark.parametrize("name", COMMANDS)
def test_every_command_says_its_version(name: str, capsys) -> None:
    with pytest.raises(SystemExit) as exit_:
        COMMANDS[name].parse_args(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out == f"{COMMANDS[name].prog} {package_version()}\n"


@pytest.mark.parametrize("name", COMMANDS)
def test_every_option_has_help_and_names_its_value(name: str) -> None:
    for action in COMMANDS[name]._actions:
        if isinstance(action, argparse._HelpAction | argparse._SubParsersAction):
            continue
        assert action.help, f"{name} {action.option_strings or action.dest}: no help"
        takes_value = action.nargs != 0 and action.option_strings
        if takes_value and action.choices is None:
            assert action.metavar, f"{name} {action.option_strings}: metavar left to argparse ({action.dest.upper()})"
            if action.dest == "instance":
                assert action.metavar == "I", f"{name} --instance {action.metavar}"
            if action.dest.endswith("port") and "key" not in action.dest:
                assert action.metavar == "P", f"{name} {action.option_strings} {action.metavar}"


@pytest.mark.parametrize("name", [name for name in COMMANDS if name.startswith("vtol ")])
def test_every_vtol_command_says_its_exit_statuses(name: str) -> None:
    epilog = COMMANDS[name].epilog or ""
    assert epilog.startswith("exit status: 0 ") and "; 2 bad arguments" in epilog, epilog


def test_the_default_controller_is_the_mpc_wherever_one_controller_is_flown() -> None:
    for name in ("vtol fly", "vtol mission"):
        (controller,) = [a for a in COMMANDS[name]._actions if a.dest == "controller"]
        assert controller.default == "mpc", name
