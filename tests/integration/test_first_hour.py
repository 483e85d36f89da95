"""A new user's first hour without surprises (issue 29, items 1 and 10), as processes of their
own: the demo keeps its databases in its own state folder (relative paths included, never in
/var/demo), a port in use or a folder that cannot be made is one line naming the fix, ``-v``
works after the command, refusals are one line on the demo's console, and a drone that has
landed at home gets a fresh battery."""

from __future__ import annotations

import re
import socket
import sqlite3
import subprocess
import threading
import time
from pathlib import Path

import httpx
import pytest

from support.processes import dronefleet, stop

pytestmark = pytest.mark.integration

VAR_DEMO = Path("/var/demo")


def said(stderr: str) -> list[str]:
    """What was said beyond argparse's usage lines."""
    return [line for line in stderr.splitlines() if line and not line.startswith((" ", "usage:"))]


def _var_demo_files() -> dict[Path, float]:
    return {p: p.stat().st_mtime for p in VAR_DEMO.rglob("*")} if VAR_DEMO.exists() else {}


def test_a_relative_state_dir_holds_the_demos_databases_and_v_after_the_command(tmp_path):
    work = tmp_path / "clone"
    work.mkdir()
    before = _var_demo_files()
    done = subprocess.run(
        dronefleet("demo", "--state-dir", "../state", "--http", "127.0.0.1:0", "--drones", "1",
                   "--speedup", "10", "--once", "-v"),
        cwd=work, capture_output=True, text=True, timeout=180,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    # -v after the command: the drones' INFO lines (issue 29: only `dronefleet -v demo` did).
    assert re.search(r"INFO +dronefleet\.drone\.app: drone QUAD_1 up", done.stderr), done.stderr
    state = tmp_path / "state"  # ../state from the clone, not /state, not /var/...
    with sqlite3.connect(state / "telemetry.db") as db:
        (rows,) = db.execute("SELECT count(*) FROM telemetry WHERE drone = 'QUAD_1'").fetchone()
    assert rows > 0
    assert (state / "ground.db").stat().st_size > 0
    assert _var_demo_files() == before  # nothing written to /var/demo
    assert not (work / "state").exists()


def test_a_state_dir_that_cannot_be_made_is_one_line(tmp_path):
    (tmp_path / "a-file").write_text("")
    done = subprocess.run(
        dronefleet("demo", "--state-dir", str(tmp_path / "a-file" / "state")),
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    (line,) = said(done.stderr)
    assert f"cannot make the state folder {tmp_path}/a-file/state: Not a directory" in line
    assert "--state-dir DIR" in line


def test_a_port_in_use_names_the_port_and_the_fix(tmp_path, mosquitto_broker):
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        demo = subprocess.run(
            dronefleet("demo", "--state-dir", str(tmp_path / "d"), "--http", f"127.0.0.1:{port}"),
            capture_output=True, text=True, timeout=60,
        )  # fmt: skip
        ground = subprocess.run(
            dronefleet("ground", "--broker", str(mosquitto_broker), "--http", f"127.0.0.1:{port}",
                       "--state", str(tmp_path / "g.db"), "--store", "sqlite:///t.db"),
            capture_output=True, text=True, timeout=60, cwd=tmp_path,
        )  # fmt: skip
    for done in (demo, ground):
        assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
        (line,) = said(done.stderr)
        assert f"127.0.0.1:{port} is already in use" in line
        assert "--http HOST:PORT" in line


def test_help_shows_the_defaults_and_an_example():
    done = subprocess.run(dronefleet("demo", "--help"), capture_output=True, text=True, timeout=60)
    text = " ".join(done.stdout.split())  # argparse wraps lines
    for default in ("127.0.0.1:8080", "var/demo", "2", "3", "60"):
        assert f"(default: {default})" in text, text
    assert "examples: dronefleet demo" in text
    assert "-v, --verbose" in text


class Demo:
    """``dronefleet demo`` running, its stdout read line by line as it comes."""

    def __init__(self, tmp_path: Path, *options: str) -> None:
        self.stderr = tmp_path / "stderr.log"
        with self.stderr.open("w") as err:
            self.proc = subprocess.Popen(
                dronefleet("demo", "--http", "127.0.0.1:0", "--state-dir", str(tmp_path / "s"),
                           *options),
                stdout=subprocess.PIPE, stderr=err, text=True,
            )  # fmt: skip
        self.lines: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip())

    def wait_for(self, pattern: str, timeout_s: float = 60) -> re.Match[str]:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for line in list(self.lines):
                if match := re.search(pattern, line):
                    return match
            assert self.proc.poll() is None, self.stderr.read_text()
            time.sleep(0.1)
        raise AssertionError(f"no {pattern!r} in {self.lines}")


def test_refusals_are_one_line_on_the_console_and_a_landed_drone_recharges(tmp_path):
    demo = Demo(tmp_path, "--drones", "2", "--speedup", "4", "--recharge-s", "5")
    try:
        url = demo.wait_for(r"^web UI: (\S+?)/?$")[1]
        token = demo.wait_for(r"^operator token: (\S+)$")[1]
        assert demo.wait_for(r"^sign in \(open in a browser\): ")
        demo.wait_for(r"QUAD_1 step +step +3 navigate")  # the demo mission is flying
        with httpx.Client(base_url=url, headers={"Authorization": f"Bearer {token}"}) as api:
            busy = api.post("/api/v1/drones/QUAD_1/commands/takeoff", json={"value": 20})
            assert busy.status_code == 409, busy.text  # flying the demo mission
            unarmed = api.post("/api/v1/drones/QUAD_2/commands/takeoff", json={"value": 20})
            assert unarmed.status_code >= 400, unarmed.text
            demo.wait_for(r"QUAD_1 completed", timeout_s=90)
            deadline = time.monotonic() + 30  # 5 vehicle s at home at 4x, and a heartbeat
            while (pct := _battery(api, "QUAD_1")) < 99.5:
                assert time.monotonic() < deadline, f"QUAD_1 still at {pct:.1f} %"
                time.sleep(0.3)
    finally:
        stop(demo.proc)
    stderr = demo.stderr.read_text()
    assert "Traceback" not in stderr, stderr


def _battery(api: httpx.Client, drone_id: str) -> float:
    return float(api.get(f"/api/v1/drones/{drone_id}").json()["battery"]["remaining_pct"])
