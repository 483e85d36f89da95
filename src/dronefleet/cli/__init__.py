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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="dronefleet", description="Plan, run and watch missions flown by one drone or many."
    )
    parser.add_argument("--version", action="version", version=f"dronefleet {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name and name.startswith(exc.name):
                continue
            raise
        module.register(sub)
    return parser


def setup_logging(verbosity: int) -> None:
    """Log to stderr, one line per record (log_lines.py: nothing received can forge a line)."""
    level = logging.WARNING - 10 * verbosity
    handler = logging.StreamHandler()
    handler.setFormatter(
        OneLineFormatter("%(asctime)s %(levelname)-7s %(name)s: %(message)s", "%H:%M:%S")
    )
    logging.basicConfig(level=max(level, logging.DEBUG), handlers=[handler])


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    setup_logging(args.verbose)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return 130
    except (OSError, ValueError, RuntimeError) as exc:
        # A port in use, a folder that cannot be written, a broker that is not there: what went
        # wrong in one line (issue 11); the traceback is for -v.
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
