"""A stolen drone cannot disturb the fleet (issue 25): holding drone A's broker credentials, or
none at all, an attacker tries every way around the topic rules a broker offers — Wills (plain
and retained) on another drone's and on the ground's topics, retained publishes, subscriptions to
``#`` and ``+/…``, CONNECTs with other clients' ids (anonymous, with a wrong password, with A's
own valid password) and resuming another client's persistent session.

Each test runs on every broker the fleet supports, started for real: the embedded default (a
broker process), the in-process bus of the simulations, Mosquitto with the password and ACL files
the project writes, and RabbitMQ with the definitions it writes (where the machine has its MQTT
adapter). The victims are the project's own broker clients, subscribed as the Drone Controller
and the Mission Planner are; every test first shows that what it looks for can happen (A's Will
on its own topic does reach the ground; the ground's command does reach B), so an empty result
means refused, not unobserved.
"""

from __future__ import annotations

import asyncio
import json

import pytest

from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.local_bus import Will
from support.fleet_brokers import KINDS, Target, target
from support.ground_procs import rabbit_mqtt_or_skip

pytestmark = pytest.mark.integration

ARM = json.dumps({"request_id": "0" * 32, "command": "arm"}).encode()
TAKEOFF = json.dumps({"request_id": "1" * 32, "command": "takeoff", "altitude": 15}).encode()
#: How long a message that got through would take to show.
SETTLE_S = 1.5


def critical(drone_id: str) -> bytes:
    return json.dumps(
        {
            "drone_id": drone_id,
            "level": "CRITICAL",
            "message": "battery 3 %",
            "position": {"lat": 40.63, "lon": -8.66, "alt": 20.0},
            "vehicle_time_s": 1.0,
        }
    ).encode()


@pytest.fixture(params=KINDS)
async def broker(request, tmp_path):
    def rabbit_port() -> int:
        return rabbit_mqtt_or_skip()[1]

    async with target(request.param, tmp_path, rabbit_port) as found:
        yield found


class Listener:
    """One of the project's own clients, as a fleet component connects: what it heard."""

    def __init__(self, client: BrokerClient) -> None:
        self.client = client
        self.got: list[tuple[str, bytes]] = []

    async def on(self, topic: str, payload: bytes) -> None:
        self.got.append((topic, payload))

    async def hears(self, topic: str, payload: bytes, timeout_s: float = 5.0) -> bool:
        for _ in range(int(timeout_s / 0.05)):
            if (topic, payload) in self.got:
                return True
            await asyncio.sleep(0.05)
        return False


async def listener(
    broker: Target, who: str, base_id: str, patterns: list[str], *, persistent: bool = False
) -> Listener:
    client = BrokerClient(broker.url_of(who), base_id, persistent_session=persistent)
    found = Listener(client)
    await client.start()
    for pattern in patterns:
        await client.subscribe(pattern, found.on)
    return found


async def fleet(broker: Target) -> tuple[Listener, Listener, BrokerClient]:
    """Drone B's controller, the ground's planner, and the ground's command sender."""
    b = broker.names["B"]
    drone_b = await listener(broker, "B", f"{b}-controller", [f"{b}/control/in", f"{b}/mission/in"])
    planner = await listener(
        broker, "ground", "ground-planner", ["+/alarms/out", "+/mission/out"], persistent=True
    )
    sender = await BrokerClient(broker.url_of("ground"), "ground-manager").start()
    await asyncio.sleep(0.3)  # subscriptions in place on every broker
    return drone_b, planner, sender


async def stop(*clients: BrokerClient | Listener) -> None:
    for each in clients:
        await (each.client if isinstance(each, Listener) else each).stop()


async def still_served(broker: Target, drone_b: Listener, planner: Listener, sender) -> None:
    """B still hears the ground's commands and the planner still hears B: nobody was cut off or
    deafened, on the same connection as before."""
    b = broker.names["B"]
    word = f'{{"probe": {len(drone_b.got) + len(planner.got)}}}'.encode()
    await sender.publish(f"{b}/control/in", word)
    assert await drone_b.hears(f"{b}/control/in", word), f"{b}'s controller was deafened"
    async with BrokerClient(broker.url_of("B"), f"{b}-failsafe") as b_out:
        await b_out.publish(f"{b}/alarms/out", word)
    assert await planner.hears(f"{b}/alarms/out", word), "the planner was deafened"
    assert drone_b.client.connections == 1, f"{b}'s controller was cut off"
    assert planner.client.connections == 1, "the planner was cut off"


@pytest.mark.parametrize("retain", [False, True], ids=["will", "retained-will"])
async def test_a_stolen_drones_will_reaches_no_other_drone_and_no_ground(broker, retain):
    a, b = broker.names["A"], broker.names["B"]
    drone_b, planner, sender = await fleet(broker)
    try:
        forged = [
            (f"{b}/control/in", ARM),
            (f"{b}/control/in", TAKEOFF),
            (f"{b}/mission/in", TAKEOFF),
            (f"{b}/alarms/out", critical(b)),
            ("ground/planner/events", b'{"event": "forged"}'),
            ("ground/presence/ground-planner", b'{"instance": "forged"}'),
        ]
        for n, (topic, payload) in enumerate(forged):
            probe = await broker.probe(
                f"{a}-w{n}", broker.logins["A"], will=Will(topic, payload, 1, retain)
            )
            await probe.drop()
        # The control: A's Will on its own alarm topic does reach the ground.
        own = await broker.probe(
            f"{a}-own", broker.logins["A"], will=Will(f"{a}/alarms/out", critical(a), 1, False)
        )
        await own.drop()
        assert await planner.hears(f"{a}/alarms/out", critical(a)), "a Will was never published"
        await asyncio.sleep(SETTLE_S)
        assert drone_b.got == [], "a forged Will reached drone B"
        assert [t for t, _ in planner.got] == [f"{a}/alarms/out"], planner.got
        # Nothing was kept for later: a new session of B's finds no retained command.
        late = await broker.probe(f"{b}-late", broker.logins["B"])
        await late.subscribe(f"{b}/control/in")
        await late.subscribe(f"{b}/mission/in")
        await asyncio.sleep(SETTLE_S)
        assert late.got == [], late.got
        await still_served(broker, drone_b, planner, sender)
    finally:
        await stop(drone_b, planner, sender)


async def test_a_stolen_drone_subscribing_to_everything_hears_nothing_of_the_others(broker):
    a, b = broker.names["A"], broker.names["B"]
    drone_b, planner, sender = await fleet(broker)
    try:
        filters = ["#", "+/control/in", "+/+/+", "+/alarms/out", "+/telemetry/out", f"{b}/#",
                   "ground/#", "$SYS/#", f"{b}/control/in"]  # fmt: skip
        spies = []
        for n, pattern in enumerate(filters):  # one connection each: some brokers cut it off
            spy = await broker.probe(f"{a}-spy{n}", broker.logins["A"])
            await spy.subscribe(pattern)
            spies.append(spy)
        await asyncio.sleep(0.3)
        await sender.publish(f"{b}/control/in", ARM)
        await sender.publish("ground/presence/ground-planner", b'{"instance": "x"}', retain=True)
        async with BrokerClient(broker.url_of("B"), f"{b}-telemetry") as b_out:
            await b_out.publish(f"{b}/telemetry/out", b"{}", retain=True)
            await b_out.publish(f"{b}/alarms/out", critical(b))
        assert await drone_b.hears(f"{b}/control/in", ARM)  # the control: it was sent
        await asyncio.sleep(SETTLE_S)
        for pattern, spy in zip(filters, spies, strict=True):
            assert [t for t, _ in spy.got if not t.startswith(f"{a}/")] == [], (pattern, spy.got)
        # Retained messages held for others do not leak to a new session either.
        late = await broker.probe(f"{a}-late", broker.logins["A"])
        await late.subscribe("ground/#")
        await late.subscribe(f"{b}/telemetry/out")
        await asyncio.sleep(SETTLE_S)
        assert late.got == []
        await still_served(broker, drone_b, planner, sender)
    finally:
        await stop(drone_b, planner, sender)


async def test_a_stolen_drones_retained_publish_waits_for_no_one(broker):
    a, b = broker.names["A"], broker.names["B"]
    forger = await broker.probe(f"{a}-forger", broker.logins["A"])
    await forger.publish(f"{b}/control/in", ARM, retain=True)
    await forger.publish(f"{b}/mission/in", TAKEOFF, retain=True)
    await asyncio.sleep(0.5)
    drone_b = await listener(broker, "B", f"{b}-controller", [f"{b}/control/in", f"{b}/mission/in"])
    try:
        await asyncio.sleep(SETTLE_S)
        assert drone_b.got == []
    finally:
        await stop(drone_b)


@pytest.mark.parametrize("login", ["anonymous", "wrong password", "own password"])
async def test_connects_with_other_clients_ids_cut_no_one_off(broker, login):
    a, b = broker.names["A"], broker.names["B"]
    drone_b, planner, sender = await fleet(broker)
    credentials = {
        "anonymous": None,
        "wrong password": (broker.logins["B"][0], "not-the-password"),
        "own password": broker.logins["A"],
    }[login]
    # What an attacker can know: the ids the components are named by. The ids on the wire carry
    # an unguessable tail; only clients the broker refuses may try those (a broker that admits
    # the caller lets it take over any id it knows: MQTT 3.1.1, 3.1.4).
    ids = [f"{b}-controller", "ground-planner", f"{a}-controller"]
    if login != "own password" or broker.kind == "local":  # the bus binds ids to their users
        ids += [drone_b.client.client_id, planner.client.client_id]
    try:
        for client_id in ids:
            for clean in (True, False):
                probe = await broker.probe(client_id, credentials, clean=clean)
                await asyncio.sleep(0.2)
                assert not [t for t, _ in probe.got if not t.startswith(f"{a}/")], probe.got
                await probe.close()
        await still_served(broker, drone_b, planner, sender)
    finally:
        await stop(drone_b, planner, sender)


async def test_a_persistent_session_is_inherited_by_no_one_and_loses_nothing(broker):
    b = broker.names["B"]
    planner = await listener(broker, "ground", "ground-planner", ["+/mission/out"], persistent=True)
    session_id = planner.client.client_id
    await asyncio.sleep(0.3)
    await planner.client.stop()  # the ground restarts: its session waits for it
    reports = [f'{{"report": {n}}}'.encode() for n in range(3)]
    async with BrokerClient(broker.url_of("B"), f"{b}-controller") as drone_b:
        for report in reports:
            await drone_b.publish(f"{b}/mission/out", report)
    await asyncio.sleep(0.5)
    for client_id, credentials in [
        ("ground-planner", broker.logins["A"]),
        (session_id, None),
        (session_id, (broker.logins["ground"][0], "not-the-password")),
        *([(session_id, broker.logins["A"])] if broker.kind == "local" else []),
    ]:
        thief = await broker.probe(client_id, credentials, clean=False)
        await thief.subscribe("+/mission/out")
        await asyncio.sleep(0.5)
        assert thief.got == [], (client_id, thief.got)
        await thief.close()
    back = await listener(broker, "ground", "ground-planner", ["+/mission/out"], persistent=True)
    try:
        assert back.client.client_id == session_id
        for report in reports:
            assert await back.hears(f"{b}/mission/out", report), f"{report!r} was lost"
    finally:
        await stop(back)
