"""UAVTalk flight-controller backend (``--fc uavtalk``): the seed's protocol to dRonin boards.

The seed's Flight Controller Interface (4.1.2.1) spoke UAVTalk over USB to a dRonin flight
controller, exchanging UAVObjects defined in XML. The pieces, bottom up:

* :mod:`.framing` — frames, CRC-8 and the streaming parser;
* :mod:`.objects` — UAVObject definitions, packing, object ids;
* :mod:`.registry` — loading the definitions from ``definitions/*.xml``;
* :mod:`.link` — the TCP session: requests, acked writes with retries, subscriptions;
* :mod:`.clock` — vehicle time from the autopilot's ``SystemStats``;
* :mod:`.backend` — the :class:`~dronefleet.vehicle.base.FlightController`.

``open_flight_controller("tcp:HOST:PORT")`` is what ``dronefleet drone --fc uavtalk --fc-url``
calls (see :mod:`dronefleet.drone.fc.factory`). A serial dRonin board can be reached through a
serial-to-TCP bridge (e.g. ``ser2net``); our simulator serves UAVTalk over TCP directly
(:mod:`dronefleet.sim.uavtalk`).
"""

from __future__ import annotations

from typing import Any

from dronefleet.drone.fc.uavtalk.backend import UAVTalkFlightController, si_view
from dronefleet.drone.fc.uavtalk.link import LinkError, Refused, UAVTalkLink
from dronefleet.protocols.uavtalk.address import parse_tcp_url
from dronefleet.protocols.uavtalk.registry import ObjectRegistry, default_registry

__all__ = [
    "LinkError",
    "ObjectRegistry",
    "Refused",
    "UAVTalkFlightController",
    "UAVTalkLink",
    "default_registry",
    "open_flight_controller",
    "si_view",
]


async def open_flight_controller(url: str, **options: Any) -> UAVTalkFlightController:
    """Connect to the UAVTalk autopilot at ``tcp:HOST:PORT``.

    Options: ``timeout_s`` and ``retries`` (per transaction), ``telemetry_rate_hz``,
    ``registry`` (an :class:`ObjectRegistry` with other definitions).
    """
    try:
        host, port = parse_tcp_url(url)
    except ValueError as exc:
        raise LinkError(str(exc)) from exc
    link = UAVTalkLink(
        host,
        port,
        options.get("registry"),
        timeout_s=options.get("timeout_s", 1.0),
        retries=options.get("retries", 3),
    )
    fc = UAVTalkFlightController(link, telemetry_rate_hz=options.get("telemetry_rate_hz", 5.0))
    try:
        await fc.connect()
    except BaseException:
        await link.close()
        raise
    return fc
