"""Argument types shared by the subcommands: a mistake is reported by argparse as one line with
the usage (exit 2), before anything starts (issue 11)."""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
from pathlib import Path

from dronefleet.messaging.url import BrokerUrl


def broker_url(text: str) -> str:
    """``--broker``: an ``mqtt://[user:pass@]host[:port]`` URL (checked, passed on as given)."""
    try:
        url = BrokerUrl.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"{exc} (e.g. mqtt://127.0.0.1:1883)") from None
    if url.ca_file is not None and not os.access(url.ca_file, os.R_OK):
        raise argparse.ArgumentTypeError(f"the broker's CA file {url.ca_file} cannot be read")
    return text


#: Where a broker password may come from besides a file: never only the command line, which
#: every user of the machine can read in ``ps`` (issue 12).
PASSWORD_ENV = "DRONEFLEET_BROKER_PASSWORD"


def add_broker_password(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--broker-password-file",
        type=Path,
        help=f"file holding the broker password of the --broker user (or set {PASSWORD_ENV})",
    )


def broker_with_password(url: str, password_file: Path | None) -> str:
    """``url`` with the password from ``password_file`` or the environment, if it has none."""
    parsed = BrokerUrl.parse(url)
    if parsed.password:
        return url
    if password_file is not None:
        secret = password_file.read_text().strip()
    else:
        secret = os.environ.get(PASSWORD_ENV, "")
    if not secret:
        return url
    if not parsed.username:
        raise ValueError("a broker password needs a user: --broker mqtt://USER@HOST:PORT")
    return dataclasses.replace(parsed, password=secret).full()


def port_number(text: str) -> int:
    if not text.isdigit() or not 0 < int(text) < 65536:
        raise argparse.ArgumentTypeError(f"a port is 1-65535, not {text!r}")
    return int(text)


def positive_speedup(text: str) -> float:
    """``--speedup`` of a process on the wall clock (and other such figures, e.g. seconds): a
    positive, finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}") from None
    if not value > 0 or not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a positive number, not {text!r}")
    return value
