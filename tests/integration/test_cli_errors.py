"""Common mistakes on the command line get one line that says what is wrong and exit 2, never a
traceback (issue 11: a non-mqtt:// broker URL, a port in use — 47 lines of traceback —, an
unwritable state folder, MAVLink port 99999 and --speedup -1 all used to end in tracebacks)."""

from __future__ import annotations

import socket
import sqlite3
import subprocess

import pytest

from support.processes import dronefleet

pytestmark = pytest.mark.integration


def run(*args: str) -> tuple[int, str]:
    done = subprocess.run(dronefleet(*args), capture_output=True, text=True, timeout=60)
    return done.returncode, done.stderr


def said(stderr: str) -> list[str]:
    """What was said beyond argparse's usage lines."""
    return [line for line in stderr.splitlines() if line and not line.startswith((" ", "usage:"))]


@pytest.mark.parametrize(
    ("args", "reason"),
    [
        (("ground", "--broker", "http://127.0.0.1:1883"), "scheme must be mqtt://"),
        (("drone", "--broker", "127.0.0.1:notaport"), "invalid port"),
        (("sim", "--count", "1", "--mavlink", "udp:127.0.0.1:99999"), "a port is 1-65535"),
        (("demo", "--speedup", "-1"), "must be positive"),
        (("drone", "--speedup", "-1"), "must be a positive number"),
        (("demo", "--state-dir", "/etc/hostname/var"), "Not a directory"),
        (("ground", "--tiles", "/nonexistent/field.mbtiles"), "no readable MBTiles file"),
        (("demo", "--tiles", "https://tiles.example/{z}/{x}.png"), "needs {y}"),
        (("ground", "--geocoder", "nominatim.example"), "expected an http(s) URL"),
    ],
)
def test_a_mistake_is_one_line_and_exit_2(args, reason):
    code, stderr = run(*args)
    assert code == 2, stderr
    assert "Traceback" not in stderr
    (line,) = said(stderr)
    assert reason in line


def test_a_file_that_is_not_mbtiles_is_one_line_and_exit_2(tmp_path):
    (tmp_path / "field.mbtiles").write_bytes(b"not a database" * 100)
    code, stderr = run(
        "demo",
        "--state-dir",
        str(tmp_path),
        "--http",
        "127.0.0.1:0",
        "--tiles",
        str(tmp_path / "field.mbtiles"),
    )
    assert code == 2 and "Traceback" not in stderr, stderr
    (line,) = said(stderr)
    assert "is not an MBTiles file" in line


def test_a_port_in_use_is_one_line_and_exit_2(tmp_path, mosquitto_broker):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        code, stderr = run(
            "ground", "--broker", str(mosquitto_broker), "--http", f"127.0.0.1:{port}",
            "--state", str(tmp_path / "g.db"), "--store", f"sqlite:///{tmp_path}/t.db",
        )  # fmt: skip
    assert code == 2, stderr
    assert "Traceback" not in stderr
    (line,) = said(stderr)
    assert "in use" in line


@pytest.mark.parametrize("option", ["--state", "--store"])
def test_a_file_that_is_not_a_database_is_one_line_exit_2_and_left_as_it_was(
    tmp_path, mosquitto_broker, option
):
    """It printed a traceback and then never exited: the connection's thread (not a daemon)
    was left open with the file it could not use."""
    garbage = tmp_path / "not-a-database.db"
    garbage.write_bytes(bytes(range(256)) * 20)
    files = {"--state": str(tmp_path / "g.db"), "--store": f"sqlite:///{tmp_path}/t.db"}
    files[option] = str(garbage) if option == "--state" else f"sqlite:///{garbage}"
    code, stderr = run(
        "ground", "--broker", str(mosquitto_broker), "--http", "127.0.0.1:0",
        "--state", files["--state"], "--store", files["--store"],
    )  # fmt: skip
    assert code == 2 and "Traceback" not in stderr, stderr
    (line,) = said(stderr)
    assert f"{option} " in line and "cannot be used: file is not a database" in line
    assert garbage.read_bytes() == bytes(range(256)) * 20


@pytest.mark.parametrize(
    "command",
    [
        ("credentials", "add-drone", "QUAD_1", "--password-file", "secret"),
        ("broker-config", "--out", "mosquitto"),
    ],
)
def test_the_fleets_users_on_a_state_that_is_not_a_database_are_one_line(tmp_path, command):
    garbage = tmp_path / "not-a-database.db"
    garbage.write_bytes(bytes(range(256)) * 20)
    *words, last = command
    code, stderr = run(*words, str(tmp_path / last), "--state", str(garbage))
    assert code == 2 and "Traceback" not in stderr, stderr
    (line,) = said(stderr)
    assert "cannot be used: file is not a database" in line
    assert garbage.read_bytes() == bytes(range(256)) * 20


def test_another_programs_database_as_state_is_one_line_and_left_as_it_was(
    tmp_path, mosquitto_broker
):
    """``CREATE TABLE IF NOT EXISTS`` kept their ``drones`` table, and the first query on it
    ended the ground in a traceback ("no such column: name")."""
    theirs = tmp_path / "inventory.db"
    with sqlite3.connect(theirs) as db:
        db.execute("CREATE TABLE drones (serial TEXT, bought TEXT)")
    db.close()
    before = theirs.read_bytes()
    code, stderr = run(
        "ground", "--broker", str(mosquitto_broker), "--http", "127.0.0.1:0",
        "--state", str(theirs), "--store", f"sqlite:///{tmp_path}/t.db",
    )  # fmt: skip
    assert code == 2 and "Traceback" not in stderr, stderr
    (line,) = said(stderr)
    assert "its table drones is not the ground's" in line
    assert theirs.read_bytes() == before


def test_a_drones_reports_file_that_is_not_a_database_is_one_line(tmp_path, mosquitto_broker):
    (tmp_path / "reports.db").write_bytes(bytes(range(256)) * 20)
    code, stderr = run(
        "drone", "--id", "QUAD_1", "--broker", str(mosquitto_broker),
        "--state-dir", str(tmp_path),
    )  # fmt: skip
    assert code == 2 and "Traceback" not in stderr, stderr
    (line,) = said(stderr)
    assert "--state-dir" in line and "reports.db cannot be used: file is not a database" in line
    assert (tmp_path / "reports.db").read_bytes() == bytes(range(256)) * 20
