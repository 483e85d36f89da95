"""Every command's ``--help`` (issue 29, item 10): every option has a help text and shows its
default, every command an example; ``-v`` is accepted after the command; refusals logged with
their exception are one line on the console (the traceback with -v)."""

from __future__ import annotations

import argparse
import logging

import pytest

from dronefleet.cli import ConsoleFormatter, _commands, build_parser
from dronefleet.errors import Conflict

PARSER = build_parser()
COMMANDS = {command.prog: command for command in _commands(PARSER)}


def test_every_command_is_covered():
    names = {prog.removeprefix("dronefleet ") for prog in COMMANDS}
    assert {"demo", "ground", "drone", "sim", "experiment", "credentials add-drone"} <= names


@pytest.mark.parametrize("prog", sorted(COMMANDS))
def test_every_option_has_help_and_its_default_and_the_command_an_example(prog):
    command = COMMANDS[prog]
    text = " ".join(command.format_help().split())
    for action in command._actions:
        if isinstance(action, argparse._SubParsersAction):
            continue
        assert action.help, f"{prog}: {action.option_strings or action.dest} has no help"
        takes_value = action.option_strings and action.nargs != 0
        if takes_value and action.default is not argparse.SUPPRESS:
            help_text = " ".join((command._get_formatter()._expand_help(action)).split())
            assert "default" in help_text, f"{prog} {action.option_strings}: {help_text}"
    assert "examples: dronefleet " in text, f"{prog} has no example"


def test_defaults_read_as_they_are_typed():
    text = " ".join(COMMANDS["dronefleet demo"].format_help().split())
    assert "(default: 127.0.0.1:8080)" in text
    assert "(default: var/demo)" in text
    text = " ".join(COMMANDS["dronefleet sim"].format_help().split())
    assert "(default: 40.63,-8.659,10)" in text and "(default: udp:127.0.0.1:14550)" in text


@pytest.mark.parametrize(
    ("argv", "verbosity"),
    [(["demo"], 0), (["-v", "demo"], 1), (["demo", "-v"], 1), (["-v", "demo", "-vv"], 3)],
)
def test_v_before_or_after_the_command(argv, verbosity):
    args = PARSER.parse_args(argv)
    assert args.verbose + getattr(args, "verbose_after", 0) == verbosity


def _record(exc: BaseException) -> logging.LogRecord:
    try:
        raise exc
    except BaseException as caught:
        return logging.LogRecord(
            "dronefleet.x", logging.ERROR, __file__, 1, "handover of %s failed", ("M1",),
            (type(caught), caught, caught.__traceback__),
        )  # fmt: skip


def test_a_logged_refusal_is_one_line_and_a_bug_keeps_its_traceback():
    quiet = ConsoleFormatter("%(levelname)s %(message)s", "%H:%M:%S", tracebacks=False)
    line = quiet.format(_record(Conflict("QUAD_2 is busy with mission M2")))
    assert line == (
        "ERROR handover of M1 failed: QUAD_2 is busy with mission M2 (-v shows the traceback)"
    )
    assert "Traceback" in quiet.format(_record(KeyError("a bug")))
    verbose = ConsoleFormatter("%(levelname)s %(message)s", "%H:%M:%S", tracebacks=True)
    assert "Traceback" in verbose.format(_record(Conflict("QUAD_2 is busy")))
