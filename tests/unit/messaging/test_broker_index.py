"""The embedded broker's filter map (messaging/broker_index.py) under amqtt's own use of it."""

from __future__ import annotations

from dronefleet.messaging.broker_index import _Filters


def test_filters_can_change_while_amqtt_walks_them():
    """amqtt walks the filters with awaits in between (a persistent session's retained
    messages); a SUBSCRIBE meanwhile must not break that walk."""
    filters = _Filters({"A/control/in": [], "+/telemetry/out": []})
    walked = []
    for topic_filter in filters:
        walked.append(topic_filter)
        filters[f"{topic_filter}/more"] = []  # another client subscribes
        filters.pop("+/telemetry/out", None)  # and another leaves
    assert walked == ["A/control/in", "+/telemetry/out"]
    assert set(filters) == {"A/control/in", "A/control/in/more", "+/telemetry/out/more"}
    assert filters.wildcards == {"+/telemetry/out/more"}
