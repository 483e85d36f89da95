"""The one console script: ``dronefleet <command>``.

Each room registers its own subcommands from a ``cli`` module exposing ``register(subparsers)``;
this file only gathers them, so adding a command never means editing someone else's code.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import sys

from dronefleet import __version__
from dronefleet.cli.args import HelpFormatter
from dronefleet.errors import DronefleetError
from dronefleet.log_lines import OneLineFormatter

#: Modules that contribute subcommands. A missing one (a room not built yet) is skipped.
COMMAND_MODULES = (
    "dronefleet.cli.drone",
    "dronefleet.cli.sim",
    "dronefleet.cli.ground",
    "dronefleet.cli.credentials",
    "dronefleet.cli.experiments",
    "dronefleet.demo",
)


#: ``-v``'s help, before the command or after it.
VERBOSE_HELP = "more logging: -v info, -vv debug (before or after the command)"

EXAMPLES = """examples:
  dronefleet demo                      the whole platform with simulated drones (make demo)
  dronefleet demo --help               every command's options, defaults and an example
  dronefleet experiment survey         one of the seed's experiments
  dronefleet ground --broker mqtt://ground@127.0.0.1:1883 --broker-password-file ground.secret
"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="dronefleet",
        description="Plan, run and watch missions flown by one drone or many.",
        epilog=EXAMPLES,
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"dronefleet {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help=VERBOSE_HELP)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name and name.startswith(exc.name):
                continue
            raise
        module.register(sub)
    for command in _commands(parser):
        # Every command's help shows its defaults; -v works after the command too (issue 29).
        command.formatter_class = HelpFormatter
        command.add_argument(
            "-v",
            "--verbose",
            dest="verbose_after",
            action="count",
            default=argparse.SUPPRESS,
            help=VERBOSE_HELP,
        )
    return parser


def _commands(parser: argparse.ArgumentParser) -> list[argparse.ArgumentParser]:
    """Every (sub)command's parser under ``parser``, nested ones too."""
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for command in dict.fromkeys(action.choices.values()):  # aliases: once each
                found += [command, *_commands(command)]
    return found


def setup_logging(verbosity: int) -> None:
    """Log to stderr, one line per record (log_lines.py: nothing received can forge a line)."""
    level = logging.WARNING - 10 * verbosity
    handler = logging.StreamHandler()
    handler.setFormatter(
        ConsoleFormatter(
            "%(asctime)s %(levelname)-7s %(name)s: %(message)s",
            "%H:%M:%S",
            tracebacks=verbosity > 0,
        )
    )
    logging.basicConfig(level=max(level, logging.DEBUG), handlers=[handler])


class ConsoleFormatter(OneLineFormatter):
    """A refusal logged with its exception (a drone that refuses a command, a mission the
    planner cannot hand over: a :class:`~dronefleet.errors.DronefleetError`, which carries its
    reason) is one line on the console, its reason appended; its traceback only with -v
    (issue 29: expected refusals printed 30-line tracebacks on the demo's console). Any other
    exception is a bug and keeps its traceback."""

    def __init__(self, fmt: str, datefmt: str, *, tracebacks: bool) -> None:
        super().__init__(fmt, datefmt)
        self.tracebacks = tracebacks

    def format(self, record: logging.LogRecord) -> str:
        exc = record.exc_info[1] if record.exc_info else None
        if self.tracebacks or not isinstance(exc, DronefleetError):
            return super().format(record)
        reason = str(exc) or type(exc).__name__
        one_line = logging.makeLogRecord(
            {
                **record.__dict__,
                "msg": f"{record.getMessage()}: {reason} (-v shows the traceback)",
                "args": None,
                "exc_info": None,
                "exc_text": None,
            }
        )
        return super().format(one_line)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    args.verbose += getattr(args, "verbose_after", 0)  # dronefleet -v demo, dronefleet demo -v
    setup_logging(args.verbose)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return 130
    except (OSError, ValueError, RuntimeError, DronefleetError) as exc:
        # A port in use, a folder that cannot be written, a broker that is not there, a --state
        # that is not a database: what went wrong in one line (issue 11); the traceback is for -v.
        if args.verbose:
            raise
        print(f"dronefleet {args.command}: {_reason(exc)} (-v shows the details)", file=sys.stderr)
        return 2


def _reason(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.strerror:
        where = f" ({exc.filename})" if exc.filename else ""
        return f"{exc.strerror}{where}"
    return str(exc) or type(exc).__name__


if __name__ == "__main__":
    sys.exit(main())
