"""Argument types shared by the subcommands: a mistake is reported by argparse as one line with
the usage (exit 2), before anything starts (issue 11)."""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
from pathlib import Path
from typing import Any

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


#: Where :func:`note_given` keeps the options the command line gave: ``{dest: "--option"}``.
_GIVEN = "_given_options"


def note_given(parser: argparse.ArgumentParser) -> None:
    """Make ``parser`` note each option the command line gives (:func:`given_options`), so an
    option that does not apply can be refused even when it was given its default value (issue 28,
    item 6: ``dronefleet drone --fc mavlink --plume ...`` was silently ignored). Call it once every
    option is added; options added later are not noted."""
    for action in parser._actions:  # argparse has no public list of them
        if action.option_strings and not isinstance(
            action, argparse._HelpAction | argparse._VersionAction
        ):
            action.__class__ = _noting(type(action))


def given_options(args: argparse.Namespace) -> dict[str, str]:
    """``{dest: option as typed}`` of the options given on the command line, in their order
    (the last spelling of one given twice: ``--no-set-autopilot-failsafe``)."""
    return dict(getattr(args, _GIVEN, {}))


_NOTING: dict[type[argparse.Action], type[argparse.Action]] = {}


def _noting(cls: type[argparse.Action]) -> type[argparse.Action]:
    """``cls`` that also notes its option as given (one subclass per action class)."""
    if cls in _NOTING.values():
        return cls
    if cls in _NOTING:
        return _NOTING[cls]

    class Noting(cls):  # type: ignore[valid-type,misc]
        def __call__(
            self,
            parser: argparse.ArgumentParser,
            namespace: argparse.Namespace,
            values: Any,
            option_string: str | None = None,
        ) -> None:
            given = dict(getattr(namespace, _GIVEN, {}))
            given.pop(self.dest, None)
            given[self.dest] = option_string or self.option_strings[0]
            setattr(namespace, _GIVEN, given)
            super().__call__(parser, namespace, values, option_string)

    Noting.__name__ = Noting.__qualname__ = cls.__name__
    _NOTING[cls] = Noting
    return Noting


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


def proxy_address(text: str) -> str:
    """``--trusted-proxy``: a reverse proxy's IP address or network (``10.0.0.0/8``)."""
    import ipaddress

    try:
        return str(ipaddress.ip_network(text.strip(), strict=False))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a proxy's IP address or network (e.g. 127.0.0.1 or 10.0.0.0/8), got {text!r}"
        ) from None


def add_trusted_proxy(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--trusted-proxy",
        type=proxy_address,
        action="append",
        default=[],
        metavar="ADDR",
        help="a reverse proxy in front of the web server (repeatable): only its X-Forwarded-For "
        "names the client (the failed-login limit is per client); default none, header ignored",
    )


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """``--help`` for every command (issue 29): each option that takes a value ends with its
    default, unless its help already says what happens without it; switches (``--once``) are off
    unless given. The epilog (each command's examples) keeps its lines."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if not action.option_strings or action.nargs == 0 or action.default is argparse.SUPPRESS:
            return text
        if "default" in text.lower():
            return text
        shown = shown_default(action.default).replace("%", "%%")  # help strings are %-formatted
        return f"{text} (default: {shown})" if text else f"(default: {shown})"


def shown_default(value: object) -> str:
    """A default as it would be typed: ``127.0.0.1:8080``, ``2``, ``var/demo``, ``none``."""
    if value is None or value == []:
        return "none"
    if isinstance(value, tuple) and len(value) == 2 and isinstance(value[1], int):
        return f"{value[0]}:{value[1]}"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def http_bind_failure(exc: OSError, host: str, port: int) -> str | None:
    """One line for an HTTP address the web server cannot listen on: which one, and the fix
    (issue 29: it said only "[Errno 98] Address already in use"). None for other errors."""
    import errno

    where = f"[{host}]:{port}" if ":" in host else f"{host}:{port}"
    if exc.errno == errno.EADDRINUSE:
        return (
            f"the web server's address {where} is already in use (another dronefleet demo or "
            f"ground?): stop that one, or choose another address with --http HOST:PORT "
            f"(--http {host}:0 takes any free port)"
        )
    if exc.errno == errno.EADDRNOTAVAIL:
        return (
            f"cannot listen on {where}: {host} is not an address of this machine; "
            "choose another with --http HOST:PORT (e.g. 127.0.0.1:8080)"
        )
    if exc.errno == errno.EACCES:
        return (
            f"not allowed to listen on {where} (ports below 1024 need root); choose another "
            "with --http HOST:PORT (e.g. 127.0.0.1:8080)"
        )
    return None


def store_url(text: str) -> str:
    """``--store``: ``sqlite:///relative/path``, ``sqlite:////absolute/path`` (SQLAlchemy's
    convention: ground/telemetry/store.py) or ``influxdb://HOST:PORT/DB``."""
    from dronefleet.ground.telemetry.store import sqlite_path

    scheme = text.partition("://")[0]
    try:
        if scheme == "sqlite":
            sqlite_path(text)
        elif scheme not in ("influxdb", "influx"):
            raise ValueError(
                f"expected sqlite:///relative/path, sqlite:////absolute/path or "
                f"influxdb://HOST:PORT/DB, got {text!r}"
            )
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text
