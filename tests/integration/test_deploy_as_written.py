"""The README's fleet set-up works as written (issue 25 item 4).

The test reads the ``sh`` block after "Set up a fleet" in README.md and runs its lines, as root,
against Debian's Mosquitto running as its own user (``user mosquitto``: what Mosquitto does when
systemd starts it as root). Only what a test must change is changed, line by line:

- paths under ``/etc/mosquitto`` go under a temporary root (made 0755, as ``/etc`` is; pytest's
  own temporary folders are private to root, which the mosquitto user could not enter);
- ports: the broker's 1883 and the ground's 8080 become free ports, every host loopback;
- ``.venv/bin/dronefleet`` is this interpreter's ``dronefleet``; the ground's checkout and the
  drone's are one temporary folder (its ``var/`` holds the state and the password files);
- Debian's package is installed first: its ``mosquitto.conf`` and folders, under the temporary
  root; ``systemctl restart mosquitto`` starts ``mosquitto -c`` on that file, as systemd does;
- the drone's simulated vehicle gets a home and ``--speedup 10``.

A line this test does not know fails it, so the README and this test cannot drift apart. Then
a mission with a picture is flown over REST with the token the ground printed, and the picture
is fetched: the drone reaches its own camera on the ground's broker (its ``gear/in`` and
``gear/out``).
"""

from __future__ import annotations

import contextlib
import os
import pwd
import re
import shlex
import shutil
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from dronefleet.messaging.embedded import free_port
from support.brokers import MOSQUITTO, wait_port
from support.ground_procs import dronefleet, wait_http, wait_online
from support.processes import stop

pytestmark = pytest.mark.integration
README = Path(__file__).resolve().parents[2] / "README.md"
HOME = (40.63, -8.659)


def readme_fleet_steps() -> list[str]:
    """The commands of the README's fleet set-up: continuation lines joined, comments dropped."""
    text = README.read_text()
    after = text[text.index("Set up a fleet") :]
    start = after.index("```sh\n") + len("```sh\n")
    block = after[start : after.index("```", start)]
    commands: list[str] = []
    pending = ""
    for line in (raw.strip() for raw in block.splitlines()):
        if not line or line.startswith("#"):
            continue
        if line.endswith("\\"):
            pending += line[:-1] + " "
            continue
        commands.append(pending + line)
        pending = ""
    return commands


def debian_mosquitto_conf(root: Path) -> Path:
    """Debian's /etc/mosquitto/mosquitto.conf (package 2.0.11) with its paths under ``root``, and
    its folders as the package and its systemd unit make them (the broker's own: mosquitto's)."""
    mosquitto = pwd.getpwnam("mosquitto")
    for folder in ("run/mosquitto", "var/lib/mosquitto", "var/log/mosquitto"):
        (root / folder).mkdir(parents=True, exist_ok=True)
        os.chown(root / folder, mosquitto.pw_uid, mosquitto.pw_gid)
    (root / "etc/mosquitto/conf.d").mkdir(parents=True, exist_ok=True)
    conf = root / "etc/mosquitto/mosquitto.conf"
    conf.write_text(
        "# Place your local configuration in /etc/mosquitto/conf.d/\n"
        f"pid_file {root}/run/mosquitto/mosquitto.pid\n\n"
        f"persistence true\npersistence_location {root}/var/lib/mosquitto/\n\n"
        f"log_dest file {root}/var/log/mosquitto/mosquitto.log\n\n"
        f"include_dir {root}/etc/mosquitto/conf.d\n"
        "user mosquitto\n"  # its default when started as root; said aloud here
    )
    return conf


def localised(command: str, root: Path, broker_port: int, http_port: int) -> list[str]:
    """One README line with this test's paths and ports."""
    command = command.replace("/etc/mosquitto", f"{root}/etc/mosquitto")
    command = re.sub(r"\b(0\.0\.0\.0|127\.0\.0\.1|ground-host):1883\b", f"127.0.0.1:{broker_port}",
                     command)  # fmt: skip
    command = command.replace("0.0.0.0:8080", f"127.0.0.1:{http_port}")
    words = shlex.split(command)
    if words[0] == ".venv/bin/dronefleet":
        return dronefleet(*words[1:])
    return words


@pytest.fixture
def root() -> Iterator[Path]:
    if os.geteuid() != 0:
        pytest.skip(
            "needs root, as the README's fleet set-up does (it starts Mosquitto as root, which "
            "then runs as the user mosquitto); CI runs the suite as root"
        )
    try:
        pwd.getpwnam("mosquitto")
    except KeyError:
        pytest.fail("no user mosquitto: install Debian's mosquitto package (make system-deps)")
    folder = Path(tempfile.mkdtemp(prefix="dronefleet-deploy-", dir="/tmp"))
    folder.chmod(0o755)  # as / and /etc are: the mosquitto user passes through
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def test_the_readmes_fleet_set_up_flies_a_mission_with_mosquitto_as_its_own_user(root):
    steps = readme_fleet_steps()
    assert any(s.startswith(".venv/bin/dronefleet broker-config") for s in steps), steps
    checkout = root / "opt/dronefleet"  # where the README's commands run: their var/ is here
    checkout.mkdir(parents=True)
    broker_port, http_port = free_port(), free_port()
    logs = root / "logs"
    logs.mkdir()
    broker_log = root / "var/log/mosquitto/mosquitto.log"
    conf = debian_mosquitto_conf(root)  # apt-get install mosquitto, before the README's steps
    with contextlib.ExitStack() as stack:
        ground_log = drone_log = None
        for step in steps:
            command = localised(step, root, broker_port, http_port)
            if step == "systemctl restart mosquitto":
                broker = stack.enter_context(
                    started([MOSQUITTO, "-c", str(conf)], logs / "mosquitto.out", root)
                )
                try:
                    wait_port("127.0.0.1", broker_port)
                except TimeoutError:
                    raise AssertionError(_tail(broker_log, logs / "mosquitto.out")) from None
                time.sleep(0.3)  # it opens the password and ACL files after dropping root
                assert broker.poll() is None, _tail(broker_log, logs / "mosquitto.out")
                assert _uid_of(broker.pid) == pwd.getpwnam("mosquitto").pw_uid
            elif step.startswith(".venv/bin/dronefleet ground "):
                ground_log = logs / "ground.log"
                stack.enter_context(started(command, ground_log, checkout))
            elif step.startswith(".venv/bin/dronefleet drone "):
                drone_log = logs / "drone.log"
                sim = ["--home", f"{HOME[0]},{HOME[1]},10", "--speedup", "10"]
                stack.enter_context(started([*command, *sim], drone_log, checkout))
            elif step.startswith((".venv/bin/dronefleet ", "ln ")):
                done = subprocess.run(command, cwd=checkout, capture_output=True, text=True)
                assert done.returncode == 0, f"{step}\n{done.stdout}{done.stderr}"
            else:
                pytest.fail(f"the README's fleet set-up has a line this test does not know: {step}")
        assert ground_log is not None and drone_log is not None, steps
        for name in ("passwd", "acl"):
            kept = (root / "etc/mosquitto/dronefleet" / name).stat()
            assert (kept.st_mode & 0o777, pwd.getpwuid(kept.st_uid).pw_name) == (0o600, "mosquitto")
        base = f"http://127.0.0.1:{http_port}"
        wait_http(base, log=ground_log)
        token = _printed_token(ground_log)
        with httpx.Client(base_url=base, headers={"Authorization": f"Bearer {token}"},
                          timeout=30) as api:  # fmt: skip
            try:
                wait_online(api, "QUAD_1")
            except AssertionError:
                raise AssertionError(_tail(drone_log, ground_log, broker_log)) from None
            _fly_with_a_picture(api, drone_log)


@contextlib.contextmanager
def started(cmd: list[str], log: Path, cwd: Path) -> Iterator[subprocess.Popen[bytes]]:
    """``cmd`` run in ``cwd``, its output in ``log``; stopped on the way out."""
    with open(log, "ab") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT, cwd=cwd)
    try:
        yield proc
    finally:
        stop(proc)


def _fly_with_a_picture(api: httpx.Client, drone_log: Path) -> None:
    steps = [
        {"command": "arm"}, {"command": "takeoff", "value": 10},
        {"command": "navigate", "lat": HOME[0] + 0.0002, "lon": HOME[1], "altitude_delta": 10},
        {"command": "wait_for_flight"}, {"command": "takepic"}, {"command": "land"},
    ]  # fmt: skip
    made = api.post(
        "/api/v1/missions",
        params={"start": "true"},
        json={"name": "as-written", "drones": ["QUAD_1"], "steps": steps},
    )
    assert made.status_code == 201, made.text
    mission_id = made.json()["mission_id"]
    deadline = time.monotonic() + 120
    while (detail := api.get(f"/api/v1/missions/{mission_id}").json())["state"] in (
        "planned", "running",
    ):  # fmt: skip
        assert time.monotonic() < deadline, detail
        time.sleep(0.5)
    assert detail["state"] == "completed", (detail.get("error"), _tail(drone_log))
    deadline = time.monotonic() + 30
    photos = f"/api/v1/missions/{mission_id}/photos"
    while True:
        listed = api.get(photos).json()
        if any(p["stored"] for p in listed):
            break
        assert time.monotonic() < deadline, f"the picture never reached the ground: {listed}"
        time.sleep(0.5)
    jpeg = api.get(f"/api/v1/missions/{mission_id}/photos/1")
    assert jpeg.status_code == 200 and jpeg.content[:2] == b"\xff\xd8"


def _printed_token(log: Path, timeout_s: float = 10.0) -> str:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        found = re.search(r"^operator token: (\S+)$", log.read_text(), re.MULTILINE)
        if found:
            return found.group(1)
        time.sleep(0.1)
    raise AssertionError(f"the ground printed no operator token:\n{_tail(log)}")


def _uid_of(pid: int) -> int:
    status = Path(f"/proc/{pid}/status").read_text()
    return int(re.search(r"^Uid:\s+\d+\s+(\d+)", status, re.MULTILINE).group(1))  # effective


def _tail(*logs: Path) -> str:
    return "\n".join(
        f"--- {log}:\n{log.read_text(errors='replace')[-3000:]}" for log in logs if log.exists()
    )
