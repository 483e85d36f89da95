"""100,000 random and mutated payloads on the topics of a running ground and a running drone
(issue 11, must-show 5).

Before: the telemetry store gained 82 garbage field names (19 -> 101) and latitudes of 95, RSS grew
96 -> 560 MB and stayed there, handlers crashed (a command field that is an object), the log grew
33 MB, a message sent afterwards came back after ~595 s, and 20 ``report`` requests made a drone
publish 100,040 messages. After the flood here: memory within 20 % of before, no new field names
and no impossible value stored, no handler exception, a real command answered within 1 s, and a
burst of report requests answered by one replay.
"""

from __future__ import annotations

import json
import os
import random
import sqlite3
import threading
import time
from pathlib import Path

import httpx
import pytest
from paho.mqtt import client as paho

from support.brokers import mosquitto
from support.ground_procs import wait_online
from support.processes import dronefleet, process

pytestmark = pytest.mark.integration

DRONE = "FLOOD_1"
TOKEN = "flood-test-token"
COUNT = int(os.environ.get("FLOOD_COUNT", "100000"))  # the figure
TOPICS = [
    f"{DRONE}/control/in", f"{DRONE}/mission/in", f"{DRONE}/gear/in", f"{DRONE}/telemetry/out",
    f"{DRONE}/heartbeats/out", f"{DRONE}/alarms/out", f"{DRONE}/mission/out",
    f"{DRONE}/control/out", "OTHER_9/telemetry/out", "OTHER_9/heartbeats/out",
    "ground/identifier/in", "ground/planner/events",
]  # fmt: skip


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise AssertionError("no VmRSS")


def junk_value(rng: random.Random, depth: int = 0) -> object:
    kind = rng.randrange(9 if depth < 4 else 6)
    if kind == 0:
        return rng.choice([0, -1, 2**64, -(2**63), 1e308, -1e308, 1e-300, 95.5, 4e9])
    if kind == 1:
        return rng.random() * rng.choice([1, 1e3, 1e9])
    if kind == 2:
        return "".join(chr(rng.randrange(1, 0x3000)) for _ in range(rng.randrange(12)))
    if kind == 3:
        return rng.choice([None, True, False, "", "arm", "report", "takeoff"])
    if kind == 4:
        return rng.choice(["NaN", "Infinity", "-Infinity"])
    if kind == 5:
        return rng.randrange(-1000, 1000)
    if kind == 6:
        return [junk_value(rng, depth + 1) for _ in range(rng.randrange(4))]
    keys = ["command", "mission_id", "action", "steps", "fields", "lat", "drone_id", "value"]
    return {rng.choice([*keys, "k" + str(rng.randrange(99))]): junk_value(rng, depth + 1)
            for _ in range(rng.randrange(5))}  # fmt: skip


def mutated(rng: random.Random, now: float) -> dict:
    """A nearly valid message of each kind, with one thing wrong."""
    base = rng.choice([
        {"drone_id": DRONE, "timestamp": now, "vehicle_time_s": 1.0,
         "fields": {"lat": 40.6, "lon": -8.6, "battery_pct": 80.0}},
        {"command": "arm", "request_id": "r1"},
        {"mission_id": "M-flood", "steps": [{"command": "takeoff", "value": 10}]},
        {"mission_id": "M-flood", "action": "report"},
        {"query": "getgear"},
        {"drone_id": DRONE, "vehicle_time_s": 1.0, "interval_s": 5},
    ])  # fmt: skip
    key = rng.choice(list(base))
    base[key] = junk_value(rng)
    if "fields" in base and isinstance(base["fields"], dict) and rng.random() < 0.5:
        base["fields"][f"junk_{rng.randrange(10_000)}"] = rng.random()
        base["fields"]["lat"] = rng.choice([95.0, -1e308, 1e308, 40.6])
        base["timestamp"] = rng.choice([0.0, 4.1e9, now])
    return base


def payloads(rng: random.Random, now: float):
    for i in range(COUNT):
        r = i % 4
        if r == 0:
            yield rng.randbytes(rng.randrange(300))
        elif r == 1:
            yield json.dumps(junk_value(rng)).encode()
        elif r == 2:
            yield json.dumps(mutated(rng, now)).encode()
        else:
            depth = rng.choice([50, 500, 5000])
            yield ("[" * depth + "]" * depth).encode()


def flood(port: int) -> None:
    rng = random.Random(11)
    client = paho.Client(paho.CallbackAPIVersion.VERSION2, client_id="flooder")
    client.max_queued_messages_set(0)
    client.connect("127.0.0.1", port)
    client.loop_start()
    try:
        for i, payload in enumerate(payloads(rng, time.time())):
            client.publish(TOPICS[i % len(TOPICS)], payload, qos=0)
            if i % 2_000 == 0:
                time.sleep(0.05)  # let the broker keep up (it drops QoS 0 it cannot send)
    finally:
        client.loop_stop()
        client.disconnect()


def count_messages(port: int, topic: str, seconds: float, then=None) -> int:
    seen = []
    client = paho.Client(paho.CallbackAPIVersion.VERSION2, client_id="counter")
    client.on_message = lambda *_: seen.append(1)
    client.connect("127.0.0.1", port)
    client.subscribe(topic, qos=1)
    client.loop_start()
    time.sleep(0.5)
    if then is not None:
        then()
    time.sleep(seconds)
    client.loop_stop()
    client.disconnect()
    return len(seen)


def test_a_flood_of_junk_changes_nothing_and_costs_no_memory(tmp_path):
    with (
        mosquitto(tmp_path) as broker,
        httpx.Client(headers={"Authorization": f"Bearer {TOKEN}"}, timeout=10) as http,
    ):
        db = tmp_path / "telemetry.db"
        ground_cmd = dronefleet(
            "ground", "--broker", str(broker), "--store", f"sqlite:///{db}",
            "--state", str(tmp_path / "ground.db"), "--http", "127.0.0.1:0", "--token", TOKEN,
        )  # fmt: skip
        port = broker.port
        api_port = _free_port()
        ground_cmd[ground_cmd.index("127.0.0.1:0")] = f"127.0.0.1:{api_port}"
        drone_cmd = dronefleet("drone", "--id", DRONE, "--broker", str(broker), "--fc", "sim")
        with (
            process(ground_cmd, tmp_path / "ground.log") as ground,
            process(drone_cmd, tmp_path / "drone.log") as drone,
        ):
            http.base_url = f"http://127.0.0.1:{api_port}"
            _wait_http(http)
            wait_online(http, DRONE, 60)
            time.sleep(15)  # telemetry stored, caches and the allocators warm
            before = {"ground": rss_mb(ground.pid), "drone": rss_mb(drone.pid)}
            fields_before = _field_names(db)

            flooder = threading.Thread(target=flood, args=(port,))
            flooder.start()
            flooder.join(600)
            time.sleep(float(os.environ.get("FLOOD_SETTLE_S", "10")))  # what was queued drains

            started = time.monotonic()
            answer = http.post(
                f"/api/v1/drones/{DRONE}/commands/objrequest", json={"value": "GPSPosition"}
            )
            took_s = time.monotonic() - started
            assert answer.status_code == 200, answer.text
            assert took_s < 1.0, f"a real command took {took_s:.2f} s after the flood"

            def ask_reports() -> None:
                publisher = paho.Client(paho.CallbackAPIVersion.VERSION2, client_id="asker")
                publisher.connect("127.0.0.1", port)
                publisher.loop_start()
                for _ in range(20):
                    body = {"mission_id": "M-flood", "action": "report"}
                    publisher.publish(f"{DRONE}/mission/in", json.dumps(body), qos=1)
                publisher.loop_stop()
                publisher.disconnect()

            replies = count_messages(port, f"{DRONE}/mission/out", 5.0, then=ask_reports)
            after = {"ground": rss_mb(ground.pid), "drone": rss_mb(drone.pid)}
            fields_after = _field_names(db)
            worst = _extremes(db)
        logs = (tmp_path / "ground.log").read_text() + (tmp_path / "drone.log").read_text()
    print(f"RSS MB before {before}, after {after}; report replies {replies}")
    for name in before:
        assert after[name] <= before[name] * 1.2, f"RSS MB before {before}, after {after}"
    assert fields_after <= fields_before | _known_fields(), fields_after - fields_before
    assert worst["lat"][0] >= -90 and worst["lat"][1] <= 90, worst
    assert worst["battery_pct"][1] <= 100, worst
    assert "failed on a message" not in logs and "Traceback" not in logs
    assert replies <= 21, f"20 report requests made {replies} messages"
    assert len(logs) < 5_000_000


def _free_port() -> int:
    from dronefleet.messaging.embedded import free_port

    return free_port()


def _wait_http(http: httpx.Client) -> None:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if http.get("/api/v1/health").status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.2)
    raise TimeoutError("ground not up")


def _field_names(db: Path) -> set[str]:
    with sqlite3.connect(db) as conn:
        return {row[0] for row in conn.execute("SELECT DISTINCT field FROM telemetry")}


def _known_fields() -> set[str]:
    from dronefleet.messaging.telemetry_schema import FLIGHT_FIELDS

    return set(FLIGHT_FIELDS) | {"co2_ppm"}


def _extremes(db: Path) -> dict[str, tuple[float, float]]:
    with sqlite3.connect(db) as conn:
        rows = conn.execute("SELECT field, MIN(value), MAX(value) FROM telemetry GROUP BY field")
        return {field: (low, high) for field, low, high in rows}
