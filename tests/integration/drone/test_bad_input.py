"""Bad input gets an error answer with a reason, and the Drone Controller keeps serving.

Issue 2, must-show 3. The drone runs in-process on a background event loop (its own thread) so
hypothesis can throw hundreds of payloads at it over the real embedded broker.
"""

from __future__ import annotations

import asyncio
import json
import threading

import orjson
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dronefleet.drone.config import DroneConfig
from dronefleet.geo.types import LLA
from dronefleet.messaging import topics
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.codec import decode_object
from dronefleet.messaging.embedded import EmbeddedBroker
from dronefleet.messaging.topics import Channel, Direction
from dronefleet.simfleet import SimFleet

pytestmark = pytest.mark.integration
DRONE = "QUAD_FUZZ"


class BackgroundDrone:
    """Broker + simulated drone + an operator client, on an event loop in a thread."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        self.call(self._start())

    def call(self, coro, timeout_s: float = 30.0):
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(timeout_s)

    async def _start(self) -> None:
        self.broker = await EmbeddedBroker(anonymous=True).start()
        self.fleet = await SimFleet(speedup=50).start()
        await self.fleet.add_drone(
            DroneConfig(drone_id=DRONE), self.broker.url, home=LLA(40.63, -8.659, 10)
        )
        self.client = await BrokerClient(self.broker.url, "fuzzer").start()
        self.answers: asyncio.Queue = asyncio.Queue()
        await self.client.subscribe(
            topics.topic(DRONE, Channel.CONTROL, Direction.OUT),
            lambda _t, p: self.answers.put(decode_object(p)),
        )

    async def _send(self, topic_name: str, payload: bytes, timeout_s: float) -> dict:
        while not self.answers.empty():
            self.answers.get_nowait()
        await self.client.publish(topic_name, payload)
        return await asyncio.wait_for(self.answers.get(), timeout_s)

    def send(self, payload: bytes, timeout_s: float = 10.0) -> dict:
        topic_name = topics.topic(DRONE, Channel.CONTROL, Direction.IN)
        return self.call(self._send(topic_name, payload, timeout_s))

    def close(self) -> None:
        async def _stop():
            await self.client.stop()
            await self.fleet.stop()
            await self.broker.stop()

        self.call(_stop())
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5)


@pytest.fixture(scope="module")
def drone():
    d = BackgroundDrone()
    yield d
    d.close()


@pytest.mark.parametrize(
    ("payload", "reason"),
    [
        (b"{not json", "not valid JSON"),
        (b"[1, 2, 3]", "JSON object"),
        (b'"arm"', "JSON object"),
        (b"{}", "no 'command'"),
        (b'{"command": "fly_to_the_moon"}', "unknown control command"),
        (b'{"command": "navigate", "lon": 10}', "lat: Field required"),
        (b'{"command": "navigate", "lat": 91, "lon": 10}', "lat"),
        (b'{"command": "navigate", "lat": 40, "lon": -181}', "lon"),
        (b'{"command": "changeN"}', "value: Field required"),
        (b'{"command": "changeN", "value": "ten"}', "value"),
        (b'{"command": "altitude", "value": 1e9}', "value"),
        (b'{"command": "takeoff", "value": -5}', "value"),
        (b'{"command": "arm", "sneaky": 1}', "sneaky"),
        (b'{"command": "objrequest", "value": "NoSuchObject"}', "unknown object"),
        (b'{"command": "navigate", "lat": 40.63, "lon": -8.659}', "not armed"),
        (b'{"command": "sleep", "value": 1}', "unknown control command"),
    ],
)
def test_bad_command_gets_an_error_with_a_reason(drone, payload, reason):
    data = (
        orjson.loads(payload) if payload.startswith(b"{") and b"not json" not in payload else None
    )
    if isinstance(data, dict):
        data["request_id"] = "bad0001"
        payload = orjson.dumps(data)
    answer = drone.send(payload)
    assert answer["ok"] is False
    assert reason in answer["error"], answer["error"]
    if isinstance(data, dict):
        assert answer["request_id"] == "bad0001"


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=20),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=10,
)
command_names = st.sampled_from(
    [
        "arm",
        "navigate",
        "changeN",
        "changeE",
        "altitude",
        "takeoff",
        "objrequest",
        "takepic",
        "wait_for_flight",
        "bogus",
        "",
        "ARM",
    ]
)
messy_commands = st.fixed_dictionaries(
    {"command": command_names},
    optional={
        "value": json_values,
        "lat": json_values,
        "lon": json_values,
        "altitude_delta": json_values,
        "force": json_values,
    },
)


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.one_of(messy_commands, json_values.map(lambda v: v), st.binary(max_size=64)))
def test_random_payloads_always_get_exactly_one_answer(drone, payload):
    raw = payload if isinstance(payload, bytes) else json.dumps(payload).encode()
    answer = drone.send(raw)
    assert answer["drone_id"] == DRONE
    assert isinstance(answer["ok"], bool)
    if not answer["ok"]:
        assert isinstance(answer["error"], str) and answer["error"]


def test_controller_still_serves_after_the_fuzzing(drone):
    answer = drone.send(
        orjson.dumps({"command": "objrequest", "value": "FlightStatus", "request_id": "x1"})
    )
    assert answer["ok"] and answer["request_id"] == "x1"
