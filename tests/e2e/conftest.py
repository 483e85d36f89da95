"""The e2e fixtures: a ``dronefleet demo`` on loopback and Debian's Chromium driven by Playwright.

Chromium comes from ``make system-deps`` (apt's ``chromium``); Playwright cannot download
browsers here, so it is pointed at ``/usr/bin/chromium``. Screenshots go to
``test-artifacts/e2e/`` (git-ignored).
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts" / "e2e"
CHROMIUM = os.environ.get("DRONEFLEET_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
#: Metres in a degree of latitude (and of longitude at the equator), for small offsets.
M_PER_DEG = 111_320.0

LINES = {
    "url": re.compile(r"^web UI: (\S+?)/?$"),
    "operator": re.compile(r"^operator token: (\S+)$"),
    "viewer": re.compile(r"^viewer token: (\S+)$"),
    "broker": re.compile(r"^broker: (\S+)$"),
}
#: A restarted demo prints no token: it keeps accepting the ones it printed before (issue 12).
KEPT = re.compile(r"^tokens: kept from the last run")
#: How a drone run apart (``--external-drone ID``) joins the demo's broker.
JOIN = re.compile(r"^drone (\S+) may join: .* --broker (\S+) --broker-password-file (\S+)$")


@dataclass
class Demo:
    url: str
    broker: str
    process: subprocess.Popen
    operator: str | None = None  # None: a restarted demo, which keeps the last run's tokens
    viewer: str | None = None
    joins: dict[str, tuple[str, str]] = field(default_factory=dict)  # id -> (broker, secret)
    output: list[str] = field(default_factory=list)

    def stop(self) -> None:
        stop_process(self.process)


def _dronefleet() -> list[str]:
    exe = Path(sys.executable).with_name("dronefleet")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "dronefleet.cli"]


def start_process(args: list[str], log: Path) -> subprocess.Popen:
    return subprocess.Popen(
        args,
        stdout=subprocess.PIPE,
        stderr=log.open("w"),
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )


def stop_process(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def free_port() -> int:
    """A loopback TCP port nobody listens on right now (messaging/embedded.py says how)."""
    from dronefleet.messaging.embedded import free_port as drawn

    return drawn()


def start_demo(
    state: Path, *options: str, port: int = 0, log: str = "stderr.log", speedup: str = "5"
) -> Demo:
    """``dronefleet demo --no-mission`` on 127.0.0.1:`port` (0: free) with `state` as its state dir.

    `options` go on the command line (``--drones 1``, ``--tiles URL``, ...); the caller stops it
    (``demo.stop()``). Fails the test if the demo does not print its URL and tokens within 60 s.
    """
    # Speed-up 5 (the demo runs at 2 by default) so that missions end within a test.
    args = [*_dronefleet(), "demo", "--http", f"127.0.0.1:{port}", "--speedup", speedup]
    args += ["--state-dir", str(state), "--no-mission", *options]
    process = start_process(args, state / log)
    found: dict[str, str] = {}
    joins: dict[str, tuple[str, str]] = {}
    seen: list[str] = []
    deadline = time.monotonic() + 60
    assert process.stdout is not None
    wanted = set(LINES)
    while not wanted <= found.keys() and time.monotonic() < deadline:
        line = process.stdout.readline()
        if not line:
            break
        seen.append(line.rstrip())
        if KEPT.match(line.strip()):
            wanted -= {"operator", "viewer"}
        if match := JOIN.match(line.strip()):
            joins[match.group(1)] = (match.group(2), match.group(3))
        for key, pattern in LINES.items():
            if match := pattern.match(line.strip()):
                found[key] = match.group(1)
    if not wanted <= found.keys():
        stop_process(process)
        err = (state / log).read_text()[-2000:]
        pytest.fail(f"dronefleet demo did not print its URL and tokens: {seen!r}\n{err}")
    # Keep draining stdout so the demo never blocks on a full pipe.
    demo = Demo(process=process, joins=joins, **found)
    threading.Thread(target=lambda: demo.output.extend(process.stdout), daemon=True).start()
    return demo


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """``fleet_scale`` tests run last: the session's demo flies on while they take minutes, and
    the tests after them would find its batteries lower than they were written for."""
    items.sort(key=lambda item: item.get_closest_marker("fleet_scale") is not None)


@pytest.fixture(scope="session")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Demo]:
    """``dronefleet demo`` with 3 simulated drones, no demo mission, on a free loopback port."""
    demo = start_demo(tmp_path_factory.mktemp("demo"), "--external-drone", "LONE_1")
    yield demo
    demo.stop()


@pytest.fixture(scope="session")
def browser() -> Iterator[object]:
    if not Path(CHROMIUM).exists():
        pytest.fail(
            f"Chromium is missing ({CHROMIUM}): run `make system-deps` (installs Debian's chromium)"
        )
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.fail("the playwright package is missing: run `make test` (installs '.[test]')")
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True)
        yield browser
        browser.close()


class Console:
    """Console errors and uncaught exceptions of one page."""

    def __init__(self, page) -> None:
        self.errors: list[str] = []
        #: Each error with where it came from: a failed load names its resource only there.
        self.located: list[str] = []
        page.on("console", lambda m: m.type == "error" and self._said(m))
        page.on("pageerror", lambda e: self.errors.append(f"uncaught: {e}"))

    def _said(self, message) -> None:
        self.errors.append(message.text)
        self.located.append(f"{message.text} ({(message.location or {}).get('url', '?')})")

    def assert_clean(self) -> None:
        assert not self.errors, f"console errors: {self.errors}; where: {self.located}"


@pytest.fixture
def open_page(browser, demo: Demo):
    """open_page("planner", token=..., server=other_demo, **context_options) → (page, console).

    `server` is another demo than the session's (its operator token is the default then).
    """
    contexts = []

    def open_(name: str, *, token: str | None = None, server: Demo | None = None, **options):
        server = server or demo
        options.setdefault("viewport", {"width": 1280, "height": 860})
        context = browser.new_context(**options)
        contexts.append(context)
        page = context.new_page()
        console = Console(page)
        # The sign-in link the demo prints: the page trades the token for a session cookie.
        page.goto(f"{server.url}/?token={token or server.operator}#/{name}")
        page.wait_for_selector("#link-state[data-state='live']", timeout=15_000)
        page.wait_for_selector(f"#page[data-mounted='{name}']", timeout=15_000)
        return page, console

    yield open_
    for context in contexts:
        context.close()


def shot(page, name: str) -> None:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"{name}.png"), full_page=True)


@pytest.fixture
def screenshot():
    return shot


@pytest.fixture(scope="session")
def shared() -> dict[str, str]:
    """What one test leaves for the next (the planner's mission id for the replay)."""
    return {}


# -- helpers shared by the test modules ------------------------------------------------------------
def get(demo: Demo, path: str, token: str | None = None):
    """GET /api/v1{path} as the operator (or `token`)."""
    request = urllib.request.Request(
        f"{demo.url}/api/v1{path}", headers={"Authorization": f"Bearer {token or demo.operator}"}
    )
    with urllib.request.urlopen(request, timeout=20) as answer:
        return json.loads(answer.read())


def post_for(demo, path: str, body: dict | None = None) -> tuple[int, bytes]:
    """POST /api/v1{path} as the operator; the status and the body of the answer."""
    request = urllib.request.Request(
        f"{demo.url}/api/v1{path}",
        data=json.dumps(body or {}).encode(),
        headers={"Authorization": f"Bearer {demo.operator}", "Content-Type": "application/json"},
        method="POST",
    )
    try:
        with urllib.request.urlopen(request, timeout=20) as answer:
            return answer.status, answer.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read()


def post(demo, path: str, body: dict | None = None) -> int:
    """POST /api/v1{path} as the operator; the status (for clean-ups)."""
    return post_for(demo, path, body)[0]


def click_and_wait(page, button: str, done: str, timeout_ms: int = 30_000) -> None:
    """Press `button`, then wait until `done` shows; if it never does, fail with what the page
    says instead (a refusal in the planner's estimate box, the status line)."""
    from playwright.sync_api import TimeoutError as PlaywrightTimeout

    page.click(button)
    try:
        page.wait_for_selector(done, timeout=timeout_ms)
    except PlaywrightTimeout:
        said = {
            sel: page.locator(sel).first.inner_text(timeout=1_000)
            for sel in ("#plan-estimate", "#mission-status", "main")
            if page.locator(sel).count()
        }
        why = f"{done} did not show {timeout_ms} ms after {button}: {said}"
        raise AssertionError(why) from None


def click_map(page, selector: str, offsets: list[tuple[int, int]]) -> None:
    """Click the map `selector` at each (dx, dy) pixels from its centre."""
    box = page.locator(selector).bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    for dx, dy in offsets:
        page.mouse.click(cx + dx, cy + dy)
        page.wait_for_timeout(150)  # not a double click


def metres(a: dict, b: dict) -> float:
    """Ground distance between two API positions (lat, lon), flat-earth: metres apart."""
    dn = (a["lat"] - b["lat"]) * M_PER_DEG
    de = (a["lon"] - b["lon"]) * M_PER_DEG * math.cos(math.radians(a["lat"]))
    return math.hypot(dn, de)


def wait_landed_at_home(demo, drones: Sequence[str], after: float, timeout_s: float = 60.0) -> None:
    """Until each of ``drones`` reports itself disarmed within 3 m of home, in a heartbeat
    newer than ``after`` (an API timestamp); fails naming where each one is."""
    deadline = time.monotonic() + timeout_s
    while True:
        fleet = {d["drone_id"]: d for d in get(demo, "/drones")}
        ends = {
            d: (fleet[d]["state"], round(metres(fleet[d]["position"], fleet[d]["home"]), 1))
            for d in drones
        }
        fresh = all(fleet[d]["last_seen"] > after for d in drones)
        if fresh and all(state == "disarmed" and off_m < 3.0 for state, off_m in ends.values()):
            return
        assert time.monotonic() < deadline, f"not every drone down at home: {ends}"
        time.sleep(1.0)
