"""The embedded default broker: a NATS server process the project starts on a free loopback port
and stops (messaging/nats_broker.py; why NATS: docs/DESIGN.md §3).

``dronefleet demo`` and the tests that talk to other processes use it. It refuses anonymous
clients unless asked to (``anonymous=True``, for tests that want it): each user comes from
``broker.users``, and ``broker.url_for(name, role)`` makes one and gives the URL with its
credentials, which stay in the process. Simulations on virtual time (the experiments, the tests
marked ``virtual_time``) use the in-process bus instead (messaging/local_bus.py), with the same
rules: a broker in another process holds messages the virtual clock cannot see.
"""

from __future__ import annotations

from dronefleet.messaging.nats_broker import NatsBroker as EmbeddedBroker
from dronefleet.messaging.ports import PORTS, free_port

__all__ = ["PORTS", "EmbeddedBroker", "free_port"]
