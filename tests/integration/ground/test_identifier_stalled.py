"""A ground whose event loop is held up declares no drone lost for its own delay (issue 26).

A drone (a paho client on a thread of its own, so it keeps beating while the ground's loop is
blocked) beats every 0.5 s and declares it: lost after 2 s (the floor). The Drone Identifier's
loop is then blocked for 4 s with ``time.sleep``: its heartbeats wait unread in the socket. The
ground, awake again, reads them and nobody is declared lost; when the drone really stops, it is
lost about 2 s later.
"""

from __future__ import annotations

import asyncio
import json
import threading
import time

import paho.mqtt.client as mqtt
import pytest

from dronefleet.ground.fleet import DroneStatus
from dronefleet.ground.identifier import DroneIdentifier
from dronefleet.ground.state import StateStore
from dronefleet.messaging.ground_events import FleetChange
from support.ground_fakes import eventually

pytestmark = pytest.mark.integration

INTERVAL_S = 0.5


class BeatingDrone(threading.Thread):
    """Heartbeats from a thread: they keep coming whatever the test's event loop does."""

    def __init__(self, url, drone_id: str) -> None:
        super().__init__(daemon=True)
        self.drone_id = drone_id
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"beat-{drone_id}")
        self.client.connect(url.host, url.port)
        self.client.loop_start()
        self.halt = threading.Event()
        self.sent = 0

    def run(self) -> None:
        t0 = time.monotonic()
        while not self.halt.is_set():
            beat = {
                "drone_id": self.drone_id,
                "timestamp": time.time(),
                "vehicle_time_s": time.monotonic() - t0,
                "interval_s": INTERVAL_S,
                "position": {"lat": 40.63, "lon": -8.659, "alt_m": 10.0, "relative_alt_m": 0.0},
                "battery": {"remaining_pct": 97.0, "voltage_v": 16.4},
                "state": "flying",
                "mode": "GUIDED",
            }
            self.client.publish(f"{self.drone_id}/heartbeats/out", json.dumps(beat), qos=0)
            self.sent += 1
            self.halt.wait(INTERVAL_S)

    def stop(self) -> None:
        self.halt.set()
        self.join(5)
        self.client.loop_stop()
        self.client.disconnect()


async def test_a_drone_is_not_lost_for_the_grounds_stalled_loop_and_is_when_it_goes(
    broker, tmp_path
):
    state = await StateStore(tmp_path / "g.db").open()
    identifier = await DroneIdentifier(broker, state, client_id="id-stall").start()
    announced: list[tuple[str, float]] = []
    announce = identifier._announce

    async def noting(record, event):
        announced.append((event.value, time.monotonic()))
        await announce(record, event)

    identifier._announce = noting  # type: ignore[method-assign]
    drone = BeatingDrone(broker, "STALL_1")
    drone.start()
    try:
        record = await eventually(lambda: identifier.fleet.get("STALL_1"), timeout_s=5)
        await eventually(lambda: record.clock_rate is not None, timeout_s=5)
        assert record.lost_after_s(identifier.lost_after_s) == pytest.approx(2.0)
        await asyncio.sleep(1.0)
        time.sleep(4.0)  # noqa: ASYNC251 -- the ground's loop held up: twice the lost-after time
        await asyncio.sleep(2.0)  # awake again: it reads what waited and goes on
        assert record.status is DroneStatus.ONLINE
        assert FleetChange.LOST.value not in [e for e, _ in announced], announced
        assert identifier.awake.stalled_s >= 3.5
        drone.stop()
        gone = time.monotonic()
        await eventually(lambda: record.status is DroneStatus.LOST, timeout_s=6)
        took = time.monotonic() - gone
        # 2 s after its last heartbeat, which came up to 0.5 s before the thread stopped (and
        # stopping it takes a moment too).
        assert 1.0 <= took <= 3.0, took
    finally:
        drone.stop()
        await identifier.stop()
        await state.close()


async def test_a_drone_is_not_lost_while_its_heartbeats_wait_in_the_identifiers_queue(
    broker, tmp_path
):
    """A ground short of CPU: the loop runs, but the identifier's heartbeat worker is 4 s behind
    (twice the lost-after time). Its drones were heard when their heartbeats arrived, so none
    is declared lost for the backlog (bench/ground_capacity.py at 1000 drones on a loaded host:
    155 were); one that really stops still is, on time."""
    state = await StateStore(tmp_path / "g.db").open()
    identifier = await DroneIdentifier(broker, state, client_id="id-behind").start()
    (worker,) = [q for q in identifier.inbox.heartbeats._queues if q.name == "identifier"]
    take, caught_up = worker.handler, asyncio.Event()
    caught_up.set()

    async def behind(hb):
        await caught_up.wait()
        await take(hb)

    worker.handler = behind
    drone = BeatingDrone(broker, "BEHIND_1")
    drone.start()
    try:
        record = await eventually(lambda: identifier.fleet.get("BEHIND_1"), timeout_s=5)
        await eventually(lambda: record.clock_rate is not None, timeout_s=5)
        caught_up.clear()  # from now on, every heartbeat waits in the queue
        await asyncio.sleep(4.0)
        assert len(worker.items) >= 4  # they did wait
        assert record.status is DroneStatus.ONLINE
        caught_up.set()
        await eventually(lambda: not worker.items, timeout_s=5)
        assert record.status is DroneStatus.ONLINE
        caught_up.clear()  # behind again, and now the drone stops
        drone.stop()
        gone = time.monotonic()
        await eventually(lambda: record.status is DroneStatus.LOST, timeout_s=6)
        assert 1.0 <= time.monotonic() - gone <= 3.0
    finally:
        caught_up.set()
        drone.stop()
        await identifier.stop()
        await state.close()


async def test_after_its_broker_restarts_the_ground_waits_for_the_drones_bridges(tmp_path):
    """Chaos seed 108: when the ground's broker itself restarts, every drone's link to it is cut
    too, and a bridged drone comes back only at its bridge's next attempt (up to 10 s,
    messaging/bridge.py). A drone heard again within that is never declared lost; one that
    never comes back is, once the grace is over (ground/identifier.py, RECONNECT_GRACE_S)."""
    from dronefleet.ground.identifier import RECONNECT_GRACE_S
    from support.brokers import Mosquitto

    broker = Mosquitto(tmp_path)
    url = broker.start()
    state = await StateStore(tmp_path / "g.db").open()
    identifier = await DroneIdentifier(url, state, client_id="id-restart").start()
    back, gone = BeatingDrone(url, "BACK_1"), BeatingDrone(url, "GONE_1")
    try:
        for drone in (back, gone):
            drone.start()
        await eventually(lambda: {"BACK_1", "GONE_1"} <= identifier.fleet.keys(), timeout_s=5)
        back.stop()
        gone.stop()
        broker.stop(kill=True)
        await asyncio.sleep(3.0)
        broker.start()
        await eventually(lambda: identifier.inbox.heartbeats.client.connected, timeout_s=10)
        await asyncio.sleep(6.0)  # the bridge's next attempt: 3 lost-after times of silence
        back = BeatingDrone(url, "BACK_1")
        back.start()
        await asyncio.sleep(2.0)
        assert identifier.fleet["BACK_1"].status is DroneStatus.ONLINE
        assert identifier.fleet["GONE_1"].status is DroneStatus.ONLINE  # still in its grace
        await eventually(
            lambda: identifier.fleet["GONE_1"].status is DroneStatus.LOST,
            timeout_s=RECONNECT_GRACE_S + 5,
        )
        assert identifier.fleet["BACK_1"].status is DroneStatus.ONLINE
    finally:
        back.stop()
        gone.stop()
        await identifier.stop()
        await state.close()
        broker.stop()
