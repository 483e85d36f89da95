"""SQLite store URLs read as SQLAlchemy reads them (issue 29, item 1): three slashes and a
relative path, four slashes and an absolute one. ``sqlite:///var/demo/telemetry.db`` once meant
/var/demo, outside the project, shared by every clone and not writable by a user."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from dronefleet.cli.args import store_url
from dronefleet.ground.telemetry.store import open_store, sqlite_path, sqlite_url


@pytest.mark.parametrize(
    ("url", "path"),
    [
        ("sqlite:///var/demo/telemetry.db", "var/demo/telemetry.db"),
        ("sqlite:///telemetry.db", "telemetry.db"),
        ("sqlite:///../x/telemetry.db", "../x/telemetry.db"),
        ("sqlite:////var/telemetry.db", "/var/telemetry.db"),
        ("sqlite:////tmp/a b/t.db", "/tmp/a b/t.db"),
        ("sqlite://", ":memory:"),
        ("sqlite://:memory:", ":memory:"),
        ("sqlite:///:memory:", ":memory:"),
    ],
)
def test_sqlite_urls_follow_sqlalchemy(url, path):
    assert sqlite_path(url) == path
    assert open_store(url).path == path  # type: ignore[attr-defined]


def test_a_path_makes_the_url_that_names_it():
    for path in (Path("/srv/df/telemetry.db"), Path("var/demo/telemetry.db")):
        assert Path(sqlite_path(sqlite_url(path))) == path
    assert sqlite_url(Path("/srv/t.db")) == "sqlite:////srv/t.db"


def test_a_host_or_an_unknown_scheme_is_refused_by_the_option():
    with pytest.raises(ValueError, match="no host"):
        sqlite_path("sqlite://somehost/t.db")
    for bad in ("sqlite://somehost/t.db", "postgres://db/x", "telemetry.db"):
        with pytest.raises(argparse.ArgumentTypeError):
            store_url(bad)
    assert store_url("influxdb://127.0.0.1:8086/fleet") == "influxdb://127.0.0.1:8086/fleet"
