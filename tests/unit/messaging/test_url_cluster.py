"""A broker cluster in one URL (issue 27): its nodes comma-separated, with one user, password and
set of TLS options for them all; what cannot be meant that way is refused, saying why."""

from __future__ import annotations

import dataclasses

import pytest

from dronefleet.messaging.bridge import bridge_config
from dronefleet.messaging.client_ids import unguessable_id
from dronefleet.messaging.url import BrokerNode, BrokerUrl

CLUSTER = "mqtt://user:pass@127.0.0.1:4001,127.0.0.1:4002,127.0.0.1:4003"


def test_every_node_is_kept_and_the_first_is_host_and_port() -> None:
    url = BrokerUrl.parse(CLUSTER)
    assert (url.host, url.port, url.username, url.password) == ("127.0.0.1", 4001, "user", "pass")
    assert url.nodes == (
        BrokerNode("127.0.0.1", 4001),
        BrokerNode("127.0.0.1", 4002),
        BrokerNode("127.0.0.1", 4003),
    )
    assert url.full() == CLUSTER
    assert str(url) == "mqtt://user:***@127.0.0.1:4001,127.0.0.1:4002,127.0.0.1:4003"
    assert BrokerUrl.parse(url.full()) == url
    assert BrokerUrl.parse(str(url)).nodes == url.nodes  # what is shown names them all


def test_each_node_has_its_default_port_and_tls_options_are_for_all() -> None:
    url = BrokerUrl.parse("mqtts://ground@a.example,b.example:9883,c.example?cafile=/etc/ca.pem")
    assert [str(node) for node in url.nodes] == [
        "a.example:8883",
        "b.example:9883",
        "c.example:8883",
    ]
    assert url.tls and url.ca_file == "/etc/ca.pem"
    assert BrokerUrl.parse(url.full()) == url
    plain = BrokerUrl.parse("mqtt://a,b")
    assert plain.nodes == (BrokerNode("a", 1883), BrokerNode("b", 1883))


def test_a_url_changed_elsewhere_keeps_its_nodes() -> None:
    """What cli/args.py does with a password from a file, and demo.py with each drone's user."""
    url = dataclasses.replace(BrokerUrl.parse("mqtt://ground@h1:1,h2:2"), password="s,e@c:r/t")
    assert BrokerUrl.parse(url.full()) == url
    assert [node.port for node in BrokerUrl.parse(url.full()).nodes] == [1, 2]


def test_one_node_is_as_before() -> None:
    url = BrokerUrl.parse("mqtt://u:p@h:1884")
    assert url.nodes == (BrokerNode("h", 1884),) and url.more_nodes == ()
    assert url == BrokerUrl("h", 1884, "u", "p")


def test_the_client_id_does_not_depend_on_the_node() -> None:
    """A persistent session is found again on another node only under the same client id."""
    cluster = BrokerUrl.parse(CLUSTER)
    for node in cluster.nodes:
        alone = BrokerUrl(node.host, node.port, "user", "pass")
        assert unguessable_id("ground-planner", alone, persistent=True) == unguessable_id(
            "ground-planner", cluster, persistent=True
        )


@pytest.mark.parametrize(
    ("bad", "says"),
    [
        ("mqtt://u:p@h1:1,v:q@h2:2", "one user and password for all nodes"),
        ("mqtt://u:p@h1:1,u:p@h2:2", "one user and password for all nodes"),
        ("mqtt://h1:1,u:p@h2:2", "one user and password for all nodes"),
        ("mqtt://h1:1,mqtts://h2:2", "cannot mix mqtt:// and mqtts://"),
        ("mqtts://h1:1,mqtt://h2:2", "cannot mix mqtt:// and mqtts://"),
        ("mqtts://h1?cafile=/a.pem,h2?cafile=/b.pem", "TLS options are for all nodes"),
        ("mqtt://h1:1,,h2:2", "an empty node"),
        ("mqtt://h1:1,", "an empty node"),
        ("mqtt://h1:1,h2:x", "invalid port in 'h2:x'"),
        ("mqtt://h1:1,h1:1", "a node is named twice"),
        ("local://u:p@bus-a,bus-b", "an in-process bus has one name"),
        ("mqtt://", "has no host"),
    ],
)
def test_what_cannot_be_one_cluster_is_refused_saying_why(bad: str, says: str) -> None:
    with pytest.raises(ValueError, match=says.replace("?", r"\?").replace("+", r"\+")):
        BrokerUrl.parse(bad)


def test_a_local_bus_takes_no_other_nodes_even_when_built() -> None:
    with pytest.raises(ValueError, match="in-process bus"):
        BrokerUrl("bus-a", 0, local=True, more_nodes=(BrokerNode("bus-b", 0),))


def test_a_drones_bridge_refuses_a_node_list() -> None:
    """Mosquitto's bridge is given one ground address (cli: --ground HOST:PORT)."""
    with pytest.raises(ValueError, match="one ground broker"):
        bridge_config("QUAD_1", "127.0.0.1:4001,127.0.0.1", 4002)
