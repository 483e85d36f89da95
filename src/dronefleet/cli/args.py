"""Argument types shared by the subcommands: a mistake is reported by argparse as one line with
the usage (exit 2), before anything starts (issue 11)."""

from __future__ import annotations

import argparse
import math

from dronefleet.messaging.url import BrokerUrl


def broker_url(text: str) -> str:
    """``--broker``: an ``mqtt://[user:pass@]host[:port]`` URL (checked, passed on as given)."""
    try:
        BrokerUrl.parse(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"{exc} (e.g. mqtt://127.0.0.1:1883)") from None
    return text


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
