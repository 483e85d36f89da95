"""The order a client tries a cluster's nodes in, and when it pauses (messaging/node_turns.py)."""

from __future__ import annotations

import pytest

from dronefleet.messaging.node_turns import NodeTurns
from dronefleet.messaging.url import BrokerNode

A, B, C = BrokerNode("a", 1), BrokerNode("b", 2), BrokerNode("c", 3)


def failed_round(turns: NodeTurns) -> list[tuple[BrokerNode, bool]]:
    """Each node given, its attempt failing at once, and whether a pause came after it."""
    tried = []
    for _ in range(3):
        node = turns.next()
        turns.down()
        tried.append((node, turns.pause_due()))
    return tried


def test_nodes_come_round_robin_with_a_pause_after_each_failed_round() -> None:
    turns = NodeTurns((A, B, C))
    assert failed_round(turns) == [(A, False), (B, False), (C, True)]
    assert failed_round(turns) == [(A, False), (B, False), (C, True)]


def test_a_link_that_held_moves_on_at_once_then_pauses_before_its_own_node() -> None:
    turns = NodeTurns((A, B, C), stable_s=0.0)
    assert turns.next() == A
    turns.up()
    turns.down()  # held, then lost
    assert not turns.pause_due()
    assert turns.next() == B
    turns.down()
    assert not turns.pause_due()
    assert turns.next() == C
    turns.down()
    assert turns.pause_due()  # A (just lost) comes again only after a pause
    assert turns.peek() == A


def test_links_lost_at_once_still_pause_after_each_round() -> None:
    """Two clients with one id taking the session from each other: no busy loop."""
    turns = NodeTurns((A, B, C), stable_s=60.0)
    pauses = 0
    for _ in range(9):
        turns.next()
        turns.up()
        turns.down()
        pauses += turns.pause_due()
    assert pauses == 3


def test_one_node_pauses_before_every_new_attempt_as_before() -> None:
    turns = NodeTurns((A,), stable_s=0.0)
    for _ in range(3):
        assert turns.next() == A
        turns.up()
        turns.down()
        assert turns.pause_due()


def test_no_node_is_refused() -> None:
    with pytest.raises(ValueError):
        NodeTurns(())


def test_a_cluster_node_gets_longer_for_its_connack_after_each_round_without_a_link() -> None:
    turns = NodeTurns((A, B, C))
    waits = []
    for _ in range(4):
        waits.append(turns.connack_s())
        failed_round(turns)
    assert waits == [2.0, 4.0, 8.0, 10.0]
    turns.next()
    turns.up()  # a link: the next round starts short again
    turns.down()
    assert turns.connack_s() == 2.0


def test_a_single_node_keeps_the_clients_own_connack_timeout() -> None:
    assert NodeTurns((A,)).connack_s() is None
