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
    for what, path in (("CA", url.ca_file), ("certificate", url.cert_file), ("key", url.key_file)):
        if path is not None and not os.access(path, os.R_OK):
            raise argparse.ArgumentTypeError(f"the broker's {what} file {path} cannot be read")
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


#: The MAVLink signing secret: a file or the environment, never the command line (issue 12).
SIGNING_KEY_ENV = "DRONEFLEET_MAVLINK_SIGNING_KEY"


def add_signing_key(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--mavlink-signing-key-file",
        type=Path,
        help="sign the MAVLink link (MAVLink 2 signing) with the passphrase or 64-hex-digit key "
        f"in this file (or set {SIGNING_KEY_ENV}); unsigned commands are then ignored",
    )


def signing_key(key_file: Path | None) -> bytes | None:
    """The MAVLink signing key from ``key_file`` or the environment; None when neither is set.
    Raises OSError or ValueError for an unreadable or empty one."""
    from dronefleet.protocols.mavlink.codec import signing_key as derive

    if key_file is not None:
        return derive(key_file.read_text())
    secret = os.environ.get(SIGNING_KEY_ENV, "")
    return derive(secret) if secret.strip() else None


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


def tiles_source(text: str) -> str:
    """``--tiles``: a tile server's URL template (``https://HOST/{z}/{x}/{y}.png``) or a local
    MBTiles file (read and checked when the ground starts)."""
    from dronefleet.ground.manager.mbtiles import is_tile_url

    if is_tile_url(text):
        missing = [part for part in ("{z}", "{x}", "{y}") if part not in text]
        if missing:
            raise argparse.ArgumentTypeError(
                f"a tile URL template needs {', '.join(missing)} "
                "(e.g. https://HOST/{z}/{x}/{y}.png)"
            )
        return text
    path = Path(text)
    if not path.is_file() or not os.access(path, os.R_OK):
        raise argparse.ArgumentTypeError(
            f"no readable MBTiles file {text!r} "
            "(or give a tile URL template https://HOST/{z}/{x}/{y}.png)"
        )
    return text


def geocoder_url(text: str) -> str:
    """``--geocoder``: the base URL of a Nominatim-compatible geocoder (asked at ``/search``)."""
    from urllib.parse import urlsplit

    parts = urlsplit(text)
    if parts.scheme not in ("http", "https") or not parts.netloc:
        raise argparse.ArgumentTypeError(
            f"expected an http(s) URL of a Nominatim-compatible geocoder, got {text!r}"
        )
    return text
