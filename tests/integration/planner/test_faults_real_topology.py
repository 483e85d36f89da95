"""Missions survive faults in the seed's real topology (issue 13, must-show 1): a test per row.

Real processes, as in the issue's table: a ground Mosquitto; each drone's own Mosquitto bridged
to it with the configuration ``dronefleet bridge-config`` writes; ``dronefleet drone --fc sim``
per drone; ``dronefleet ground`` with its own state. A mission of eight waypoints is started over
REST and, once the drone is past its third waypoint, the row's fault is made: a part killed with
SIGKILL and started again after an outage, a drone killed for good (its work is taken over), the
ground killed right after a replacement alarm, or the bridge link slowed (500 ms each way) and
made lossy (30 %; tests/support/link_proxy.py). Each row asserts what the issue asks: every
waypoint reached, every report at the planner by its number (1..n, none missing), the mission
``completed``, its log whole.

Before this round the ground broker's row left the mission "running" forever with 125 of 172
reports lost, the drone broker's row stopped the drone at 39 of 56 waypoints, a killed drone's
mission ran forever, and the lossy link's lost 39 of 78 reports.
"""

from __future__ import annotations

import contextlib
import secrets
import sqlite3
import subprocess
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import httpx
import paho.mqtt.client as mqtt
import pytest

from dronefleet.messaging.embedded import free_port
from support.brokers import Mosquitto
from support.ground_procs import drone_cmd, ground_cmd, stop, wait_http, wait_online
from support.link_proxy import LinkProxy
from support.processes import dronefleet, process

pytestmark = pytest.mark.integration

WAYPOINTS = 8
OUTAGE_WALL_S = 4.0
HOME = (40.63, -8.659)
ENDED = ("completed", "failed", "stopped")
ALARM_AFTER = 3  # waypoints, in the alarm row


def mission(drones: list[str], *, replacement: bool = False, alarm: bool = False) -> dict:
    steps: list[dict] = [{"command": "arm"}, {"command": "takeoff", "value": 10}]
    for i in range(WAYPOINTS):
        steps += [
            {"command": "navigate", "lat": HOME[0] + 0.00012 * (i + 1), "lon": HOME[1],
             "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]  # fmt: skip
        if alarm and i + 1 == ALARM_AFTER:
            steps.append({"command": "virtualalarm", "level": "CRITICAL", "message": "smoke"})
    steps.append({"command": "land"})
    options = {"early_replacement": False, "collaboration": False, "replacement": replacement}
    return {"name": "fault", "drones": drones, "steps": steps, "options": options}


def bridge(drone_id: str, ground_port: int) -> str:
    """The bridge section ``dronefleet bridge-config`` writes for the drone."""
    args = ["bridge-config", "--drone-id", drone_id, "--ground", f"127.0.0.1:{ground_port}"]
    return subprocess.run(dronefleet(*args), check=True, capture_output=True, text=True).stdout


@dataclass
class Rig:
    """The topology of one row: brokers, drone processes, the ground process and its API."""

    tmp: Path
    drones: list[str]
    speedup: float = 10.0
    link: LinkProxy | None = None  # between the drones' bridges and the ground broker
    http: int = field(default_factory=free_port)
    token: str = field(default_factory=lambda: secrets.token_urlsafe(16))
    procs: dict[str, subprocess.Popen[bytes]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.ground_broker = Mosquitto(self.tmp)
        self.ground_log = self.tmp / "ground.log"
        self.ground_args = ground_cmd(
            self.ground_broker.url.full(), self.tmp, self.http, self.token
        )
        self.stack = contextlib.ExitStack()
        self.api = httpx.Client(
            base_url=f"http://127.0.0.1:{self.http}",
            headers={"Authorization": f"Bearer {self.token}"},
            timeout=30,
        )

    def __enter__(self) -> Rig:
        self.ground_broker.start()
        self.stack.callback(self.ground_broker.stop)
        target = self.ground_broker.port
        if self.link is not None:
            self.link.target_port = target
            target = self.stack.enter_context(_started(self.link)).port
        self.drone_brokers = {}
        for drone_id in self.drones:
            broker = Mosquitto(self.tmp, extra_conf=bridge(drone_id, target))
            broker.start()
            self.stack.callback(broker.stop)
            self.drone_brokers[drone_id] = broker
            self.start_drone(drone_id)
        self.start_ground()
        self.stack.callback(lambda: stop(self.procs["ground"]))
        self.stack.callback(self.api.close)
        for drone_id in self.drones:
            wait_online(self.api, drone_id, timeout_s=60)
        return self

    def __exit__(self, *exc: object) -> None:
        self.stack.close()

    def start_drone(self, drone_id: str) -> None:
        """``dronefleet drone`` with its reports kept in its own state folder."""
        broker = self.drone_brokers[drone_id].url.full()
        cmd = [*drone_cmd(drone_id, broker, self.speedup), "--state-dir", f"{self.tmp}/{drone_id}"]
        log = self.tmp / f"{drone_id}.log"
        self.procs[drone_id] = self.stack.enter_context(process(cmd, log))

    def start_ground(self) -> None:
        with open(self.ground_log, "ab") as out:
            self.procs["ground"] = subprocess.Popen(
                self.ground_args, stdout=out, stderr=subprocess.STDOUT
            )
        wait_http(str(self.api.base_url), timeout_s=60, log=self.ground_log)

    def kill(self, part: str) -> None:
        stop(self.procs[part], sig_kill=True)

    def start_mission(self, spec: dict) -> str:
        created = self.api.post("/api/v1/missions", params={"start": "true"}, json=spec)
        assert created.status_code == 201, created.text
        return created.json()["mission_id"]

    def until(self, mission_id: str, timeout_s: float, done: int | None = None) -> dict:
        """The mission once ``done`` steps are reported, or once it has ended (a mission whose
        drone is unheard for a while is ``stalled``, not ended: it runs again when it is back)."""
        deadline = time.monotonic() + timeout_s
        detail: dict = {}
        while time.monotonic() < deadline:
            with contextlib.suppress(httpx.HTTPError):
                answer = self.api.get(f"/api/v1/missions/{mission_id}")
                if answer.status_code == 200:
                    detail = answer.json()
                    ended = detail["state"] in ENDED
                    if ended or (done is not None and detail["steps_done"] >= done):
                        return detail
            time.sleep(0.2)
        tail = self.ground_log.read_text()[-3000:]
        raise AssertionError(f"mission {mission_id} stuck: {detail}\n{tail}")


@contextlib.contextmanager
def _started(link: LinkProxy) -> Iterator[LinkProxy]:
    link.start()
    try:
        yield link
    finally:
        link.stop()


@contextlib.contextmanager
def alarms_seen(port: int) -> Iterator[threading.Event]:
    """Set once a CRITICAL alarm reaches the ground broker (what the planner hears)."""
    seen = threading.Event()
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="fault-alarm-watch")
    client.on_message = lambda *_: seen.set()
    client.on_connect = lambda c, *_: c.subscribe("+/alarms/out", qos=1)
    client.connect("127.0.0.1", port)
    client.loop_start()
    try:
        yield seen
    finally:
        client.loop_stop()
        client.disconnect()


def assert_whole(rig: Rig, mission_id: str, after: dict) -> dict:
    """Every step done and logged, every waypoint reached, every report by number; the log."""
    steps = len(after["work"])
    assert after["state"] == "completed", (after["state"], after["error"])
    assert after["steps_done"] == steps and len(after["done"]) == steps
    assert after["waypoints_reached"] == after["waypoints"] == WAYPOINTS
    for leg in after["legs"]:  # reports 1..n of each leg, none missing
        assert leg["seqs"] == list(range(1, len(leg["seqs"]) + 1)), leg
    log = rig.api.get(f"/api/v1/missions/{mission_id}/log")
    assert log.status_code == 200, log.text
    flown = [s for d in log.json()["drones"] for s in d["steps"] if s["index"] is not None]
    assert sorted({s["index"] for s in flown}) == list(range(steps)), flown
    return log.json()


@pytest.mark.parametrize(
    "fault", ["none", "ground-broker", "drone-broker", "ground", "latency", "latency-loss"]
)
def test_a_fault_comes_and_goes_and_the_mission_completes_with_every_report(
    fault: str, tmp_path: Path
):
    drone_id = f"FAULT_{secrets.token_hex(3)}"
    link = None
    if fault.startswith("latency"):  # at 5x, as the run: the link's seconds are wall
        link = LinkProxy(0, latency_s=0.5, loss=0.3 if fault == "latency-loss" else 0.0)
    with Rig(tmp_path, [drone_id], speedup=5 if link else 10, link=link) as rig:
        mission_id = rig.start_mission(mission([drone_id]))
        before = rig.until(mission_id, timeout_s=90, done=2 + 2 * 3)
        # Over the slow, lossy link reports come late and in bursts (the last of them may close
        # the mission before 8 steps were ever seen done); a drone unheard there for a while
        # would have its mission stalled (not failed) until it is heard again.
        slow = ("running", "stalled", "completed")
        assert before["state"] in (slow if link else ("running",)), before
        if fault == "ground-broker":
            rig.ground_broker.stop(kill=True)
            time.sleep(OUTAGE_WALL_S)
            rig.ground_broker.start()
        elif fault == "drone-broker":
            rig.drone_brokers[drone_id].stop(kill=True)
            time.sleep(OUTAGE_WALL_S)
            rig.drone_brokers[drone_id].start()
        elif fault == "ground":  # killed while it stores 5 Hz telemetry (SQLite)
            rig.kill("ground")
            time.sleep(OUTAGE_WALL_S)
            rig.start_ground()
        after = rig.until(mission_id, timeout_s=240 if link else 90)
        assert_whole(rig, mission_id, after)
    if link is not None:  # everything went through it, and slowly
        assert link.chunks > 100 and (link.retransmitted > 10) == bool(link.loss), vars(link)
        print(f"link: {link.chunks} chunks, {link.retransmitted} retransmitted")
    with sqlite3.connect(tmp_path / "telemetry.db") as db:  # opens cleanly, nothing torn
        assert db.execute("PRAGMA integrity_check").fetchone() == ("ok",)
        assert db.execute("SELECT count(*) FROM telemetry").fetchone()[0] > 20


def test_a_drone_killed_for_good_has_its_unreported_steps_flown_by_another(tmp_path: Path):
    lost, spare = (f"LOST_{secrets.token_hex(3)}", f"SPARE_{secrets.token_hex(3)}")
    with Rig(tmp_path, [lost, spare]) as rig:
        mission_id = rig.start_mission(mission([lost], replacement=True))
        rig.until(mission_id, timeout_s=90, done=2 + 2 * 3)
        rig.kill(lost)  # not started again
        after = rig.until(mission_id, timeout_s=120)
        log = assert_whole(rig, mission_id, after)
    (handover,) = after["handovers"]
    assert handover["from_drone"] == lost and handover["to_drone"] == spare
    assert "lost" in handover["reason"]
    first = next(leg for leg in after["legs"] if leg["role"] == "primary")
    taken = next(leg for leg in after["legs"] if leg["role"] == "replacement")
    reported = {r["index"] for r in first["reports"] if r["index"] is not None}
    # The spare flew every step the lost drone had not reported, and of those it had at most
    # a half-done waypoint's navigate again.
    assert set(first["indices"]) - reported <= set(taken["indices"])
    assert len(set(taken["indices"]) & reported) <= 1
    waypoints = [
        s["index"]
        for d in log["drones"]
        for s in d["steps"]
        if s["index"] is not None and log["work"][s["index"]]["command"] == "wait_for_flight"
    ]
    assert sorted(waypoints) == sorted(set(waypoints))  # none reached twice


def test_the_ground_killed_right_after_a_replacement_alarm_finishes_the_handover(
    tmp_path: Path,
):
    first, spare = (f"ALARM_{secrets.token_hex(3)}", f"SPARE_{secrets.token_hex(3)}")
    # Killed as the alarm reaches the ground broker, the planner may not have had it yet; it is
    # then delivered again when the planner is back (messaging/acks.py). At 3x the drone is
    # still flying the five waypoints after the alarm then (at 10x it had finished them during
    # the 4 s outage, and a finished leg needs no replacement).
    with (
        Rig(tmp_path, [first, spare], speedup=3) as rig,
        alarms_seen(rig.ground_broker.port) as alarm,
    ):
        mission_id = rig.start_mission(mission([first], replacement=True, alarm=True))
        assert alarm.wait(90), "no alarm reached the ground broker"
        rig.kill("ground")  # as the planner hears it
        time.sleep(OUTAGE_WALL_S)
        rig.start_ground()
        after = rig.until(mission_id, timeout_s=120)
        log = assert_whole(rig, mission_id, after)
    (handover,) = after["handovers"]  # decided once, whether the alarm came again or not
    assert handover["from_drone"] == first
    # Assigned once the alarmed drone had accepted its way home (issue 26), so from what it had
    # really not flown: the spare flies the rest, or nobody if it flew it all meanwhile.
    assert handover["to_drone"] == (spare if handover["remaining_steps"] else None), handover
    waypoints = [
        s["index"]
        for d in log["drones"]
        for s in d["steps"]
        if s["index"] is not None and log["work"][s["index"]]["command"] == "wait_for_flight"
    ]
    assert sorted(waypoints) == sorted(set(waypoints))  # none reached twice


def test_a_drone_restarted_mid_mission_loses_no_report_and_its_rest_is_taken_over(
    tmp_path: Path,
):
    first, spare = (f"BOOT_{secrets.token_hex(3)}", f"SPARE_{secrets.token_hex(3)}")
    with Rig(tmp_path, [first, spare]) as rig:
        mission_id = rig.start_mission(mission([first], replacement=True))
        rig.until(mission_id, timeout_s=90, done=2 + 2 * 3)
        rig.kill(first)
        rig.start_drone(first)  # at once: it may never be missed
        after = rig.until(mission_id, timeout_s=120)
        assert_whole(rig, mission_id, after)
    (handover,) = after["handovers"]
    assert handover["from_drone"] == first and handover["to_drone"] == spare
