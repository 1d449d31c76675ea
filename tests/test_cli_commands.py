"""The mjsuff parser and main: every command is reachable, and only MjsuffError becomes one line."""

import re

import pytest

from mjsuff.cli import build_parser, main
from mjsuff.cli import hoeffding as hoeffding_command
from mjsuff.cli.commands import COMMANDS
from mjsuff.errors import MjsuffError

SCENARIO_COMMANDS = ("run", "demos", "calibrate")


def test_every_command_module_adds_one_command_that_help_lists(capsys):
    names = {"run", "demos", "calibrate", "view", "report", "scenarios", "hoeffding"}
    assert len(COMMANDS) == len(names)
    with pytest.raises(SystemExit):
        build_parser().parse_args(["--help"])
    listed = capsys.readouterr().out
    for name in names:
        assert re.search(rf"^    {name}\b", listed, re.MULTILINE), name
        with pytest.raises(SystemExit) as exit_:
            build_parser().parse_args([name, "--help"])
        assert exit_.value.code == 0


@pytest.mark.parametrize("name", SCENARIO_COMMANDS)
def test_scenario_commands_share_the_scenario_options(name):
    args = build_parser().parse_args(
        [name, "gridworld", "--seed", "3", "--set", "a=1", "--set", "b=2", "--quiet"]
    )
    assert (args.scenario, args.seed, args.set, args.quiet) == ("gridworld", 3, ["a=1", "b=2"], True)


class _Unavailable(MjsuffError):
    exit_code = 69


def test_a_mjsuff_error_is_one_line_with_its_exit_status(monkeypatch, capsys):
    def fail(*args):
        raise _Unavailable("the thing at x: nothing answers")

    monkeypatch.setattr(hoeffding_command, "abbeel_ng_demos", fail)
    assert main(["hoeffding"]) == 69
    err = capsys.readouterr().err
    assert err.strip() == "error: the thing at x: nothing answers"


def test_any_other_exception_is_a_bug_and_keeps_its_traceback(monkeypatch):
    def fail(*args):
        raise ValueError("a bug")

    monkeypatch.setattr(hoeffding_command, "abbeel_ng_demos", fail)
    with pytest.raises(ValueError, match="a bug"):
        main(["hoeffding"])


def test_out_of_memory_is_one_line_naming_the_command(monkeypatch, capsys):
    def exhausted(*args):
        raise MemoryError

    monkeypatch.setattr(hoeffding_command, "abbeel_ng_demos", exhausted)
    assert main(["hoeffding"]) == 71
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: mjsuff hoeffding: out of memory") and "\n" not in err
