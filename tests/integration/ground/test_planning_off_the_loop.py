"""Planning runs off the event loop, within a budget (issue 11, must-show 3).

Before, planning ran on the ground's event loop: a 2000-vertex outline froze the server for 17 s,
every drone was marked lost and the preview then answered 409 "drone QUAD_1 is lost". Here a
preview that takes seconds to plan (a 1,800-vertex comb of 190 m teeth at 4 m: about 1.8 s of
coverage planning on this machine, then the split) runs while a second client asks for the fleet
every 100 ms: every answer comes long before the plan is done (under a third of its time and
under 1 s; tens of milliseconds typically) and no drone is marked lost. With a budget of 0.25 s
the same preview is refused with a 422 that says what to do, and the ground goes on serving.
"""

from __future__ import annotations

import threading
import time

import httpx
import pytest

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.messaging.embedded import free_port
from support.brokers import mosquitto
from support.ground_procs import wait_online
from support.processes import dronefleet, process

pytestmark = pytest.mark.integration

HOME = LLA(40.63, -8.659, 10.0)
TOKEN = "planning-test-token"
DRONES = ("PLAN_1", "PLAN_2")


def comb(teeth: int = 450, width: float = 3.0, gap: float = 3.0) -> list[list[float]]:
    """A comb of ``teeth`` 190 m teeth: 1,802 vertices, hard to cover at 4 m (60 m teeth planned
    in 0.7 s since the whole-field route solver, and the whole preview in 1.00 s on CI: too near
    the 1 s this test needs to tell a long plan)."""
    points = [(0.0, 0.0)]
    east = 0.0
    for _ in range(teeth):
        points += [(east, 200.0), (east + width, 200.0), (east + width, 10.0)]
        east += width + gap
        points.append((east, 10.0))
    points.append((east, 0.0))
    return [[p.lat, p.lon] for p in (ned_to_lla(NED(n, e), HOME) for e, n in points)]


def spec() -> dict:
    area = {"polygon": comb(), "spacing_m": 4, "altitude_m": 20, "action": "takepic"}
    return {"name": "comb", "area": area, "drones": list(DRONES)}


def ground_up(http: httpx.Client) -> None:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if http.get("/api/v1/health").status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.2)
    raise TimeoutError("ground not up")


def run_ground(tmp_path, broker, budget_s: float):
    port = free_port()
    cmd = dronefleet(
        "ground", "--broker", str(broker), "--store", f"sqlite:///{tmp_path}/t.db",
        "--state", str(tmp_path / "g.db"), "--http", f"127.0.0.1:{port}", "--token", TOKEN,
        "--planning-budget", str(budget_s),
    )  # fmt: skip
    return process(cmd, tmp_path / f"ground-{budget_s:g}.log"), f"http://127.0.0.1:{port}"


def poll_fleet(base_url: str, stop: threading.Event, answers: list[tuple[float, dict]]) -> None:
    headers = {"Authorization": f"Bearer {TOKEN}"}
    with httpx.Client(base_url=base_url, headers=headers, timeout=10) as http:
        while not stop.is_set():
            started = time.monotonic()
            drones = http.get("/api/v1/drones").json()
            answers.append(
                (time.monotonic() - started, {d["drone_id"]: d["status"] for d in drones})
            )
            time.sleep(max(0.0, 0.1 - (time.monotonic() - started)))


@pytest.fixture
def fleet(tmp_path):
    with (
        mosquitto(tmp_path) as broker,
        process(
            dronefleet("drone", "--id", DRONES[0], "--broker", str(broker), "--fc", "sim"),
            tmp_path / "d1.log",
        ),
        process(
            dronefleet(
                "drone",
                "--id",
                DRONES[1],
                "--broker",
                str(broker),
                "--fc",
                "sim",
                "--home",
                "40.6301,-8.659,10",
            ),
            tmp_path / "d2.log",
        ),
    ):
        yield broker


def test_a_long_plan_leaves_the_ground_answering_and_no_drone_lost(tmp_path, fleet):
    ground, url = run_ground(tmp_path, fleet, budget_s=60)
    headers = {"Authorization": f"Bearer {TOKEN}"}
    with ground, httpx.Client(base_url=url, headers=headers, timeout=120) as http:
        ground_up(http)
        for drone_id in DRONES:
            wait_online(http, drone_id, 60)
        stop, answers = threading.Event(), []
        poller = threading.Thread(target=poll_fleet, args=(url, stop, answers))
        poller.start()
        try:
            started = time.monotonic()
            preview = http.post("/api/v1/missions/preview", json=spec())
            planned_s = time.monotonic() - started
        finally:
            stop.set()
            poller.join(10)
    # Planned to the end: 51 km of route, more than two sim batteries, so refused for that.
    assert preview.status_code == 422, preview.text
    assert "batteries cannot cover the route" in preview.json()["detail"]
    assert planned_s > 1.0, f"the plan took only {planned_s:.2f} s: not a long plan"
    assert len(answers) >= planned_s / 0.2
    # A loop that planned would answer only once the plan is done (seconds); one that does not
    # answers in tens of milliseconds, 0.23 s at worst seen on a loaded 2-core machine.
    slowest = max(seconds for seconds, _ in answers)
    assert slowest < min(1.0, planned_s / 3), (
        f"the fleet answered in {slowest:.3f} s while planning"
    )
    assert all(status == "online" for _, fleet in answers for status in fleet.values())


def test_a_plan_over_budget_is_a_422_that_says_what_to_do(tmp_path, fleet):
    # The comb plans in about 2 s here (1.8 s of coverage, then the split): a quarter of a second
    # is well below it, and far above the 5-tooth comb's few milliseconds.
    ground, url = run_ground(tmp_path, fleet, budget_s=0.25)
    headers = {"Authorization": f"Bearer {TOKEN}"}
    with ground, httpx.Client(base_url=url, headers=headers, timeout=60) as http:
        ground_up(http)
        for drone_id in DRONES:
            wait_online(http, drone_id, 60)
        refused = http.post("/api/v1/missions/preview", json=spec())
        assert refused.status_code == 422, refused.text
        assert "too complex to plan within 0.25 s" in refused.json()["detail"]
        assert http.get("/api/v1/drones").status_code == 200
        # A plain 60 x 60 m field plans in a few milliseconds (the 5-tooth comb used here
        # before takes about 110 ms since the whole-field route solver: too near the budget
        # on a loaded machine to show the contrast).
        square = [[p.lat, p.lon] for p in (ned_to_lla(NED(n, e), HOME) for n, e in
                  [(0, 0), (60, 0), (60, 60), (0, 60)])]  # fmt: skip
        small = {**spec(), "area": {**spec()["area"], "polygon": square}}
        answer = http.post("/api/v1/missions/preview", json=small)
        assert answer.status_code == 200, answer.text
