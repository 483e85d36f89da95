"""An answer is believed only from the asked drone's own topic (messaging/rpc.py, issue 12)."""

import asyncio

import orjson
import pytest

from dronefleet.messaging.rpc import Requester, RequestTimeout


class _Broker:
    """Just enough of a BrokerClient: remembers the handler and what was published."""

    persistent_session = False

    def __init__(self) -> None:
        self.handler = None
        self.sent: list[tuple[str, dict]] = []

    async def subscribe(self, pattern, handler, *, qos=1):
        self.handler = handler

    async def publish(self, topic_name, data, *, qos=1, timeout_s=None):
        self.sent.append((topic_name, data))


async def _ask(requester: Requester, broker: _Broker, answers: list[tuple[str, dict]]):
    task = asyncio.create_task(
        requester.request(
            "QUAD_2/control/in",
            "+/control/out",
            {"command": "takeoff"},
            timeout_s=0.5,
            reply_topic="QUAD_2/control/out",
        )
    )
    while not broker.sent:
        await asyncio.sleep(0)
    request_id = broker.sent[0][1]["request_id"]
    for topic_name, body in answers:
        await broker.handler(topic_name, orjson.dumps({**body, "request_id": request_id}))
    return await task


async def test_a_forged_answer_on_another_topic_is_ignored_and_the_real_one_counts():
    broker = _Broker()
    requester = Requester(broker)  # type: ignore[arg-type]
    answer = await _ask(
        requester,
        broker,
        [
            ("EVIL/control/out", {"drone_id": "EVIL", "ok": True}),
            ("QUAD_2/control/out", {"drone_id": "QUAD_2", "ok": False, "error": "disarmed"}),
        ],
    )
    assert answer["ok"] is False and answer["drone_id"] == "QUAD_2"
    assert requester.foreign == 1


async def test_only_forged_answers_mean_no_answer():
    broker = _Broker()
    requester = Requester(broker)  # type: ignore[arg-type]
    with pytest.raises(RequestTimeout):
        await _ask(requester, broker, [("EVIL/control/out", {"drone_id": "EVIL", "ok": True})])
