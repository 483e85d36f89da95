"""Reading the flight figures from an autopilot that queues 20 parameter requests, as ArduPilot
does (GCS_MAVLINK::param_requests): asked all at once, the 21st name on was dropped unanswered
(WP_SPD, sorted last of the 40 names, went missing from the heartbeat's flight block)."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

from dronefleet.drone.fc.mavlink import session
from dronefleet.drone.fc.mavlink.flight_params import FLIGHT_PARAMS
from dronefleet.protocols.mavlink.codec import dialect as mav
from dronefleet.protocols.mavlink.codec import text_field

QUEUE = 20  # ArduPilot's requests queued per link


class QueueingAutopilot:
    """Answers what it knows of the requests it could queue, a moment after they came."""

    target_system = 1
    target_component = 1

    def __init__(self, known: dict[str, float]) -> None:
        self.known = known
        self.queued: list[str] = []
        self.listeners: list[Callable[[Any], None]] = []

    def add_listener(self, listener: Callable[[Any], None]) -> Callable[[], None]:
        self.listeners.append(listener)
        return lambda: self.listeners.remove(listener)

    def send(self, msg: Any) -> None:
        if len(self.queued) >= QUEUE:
            return  # dropped: the queue is full
        if not self.queued:
            asyncio.get_running_loop().call_later(0.01, self.answer)
        self.queued.append(text_field(msg.param_id))

    def answer(self) -> None:
        for name in self.queued:
            if name in self.known:
                reply = mav.MAVLink_param_value_message(
                    name.encode(), self.known[name], mav.MAV_PARAM_TYPE_REAL32, 999, 0
                )
                for listener in list(self.listeners):
                    listener(reply)
        self.queued.clear()


def test_every_figure_is_read_past_the_autopilots_request_queue() -> None:
    known = {"WP_SPD": 8.0, "WP_ACC": 2.5, "BATT_CAPACITY": 5200.0, "RTL_ALT": 1500.0}
    known |= {"RTL_LOIT_TIME": 5000.0, "LAND_SPD_MS": 0.5, "CAM1_TYPE": 1.0}
    link = QueueingAutopilot(known)
    names = {n for _, candidates in FLIGHT_PARAMS for n, _ in candidates}
    assert len(names) > QUEUE  # more names than one queue holds
    values = asyncio.run(session.read_params(link, FLIGHT_PARAMS, timeout_s=0.3))  # type: ignore[arg-type]
    assert values["speed_mps"] == 8.0
    assert values["accel_mps2"] == 2.5
    assert values["capacity_mah"] == 5200.0
    assert values["rtl_alt_m"] == 15.0
    assert values["rtl_loiter_s"] == 5.0
    assert values["land_speed_mps"] == 0.5
    assert "climb_mps" not in values  # a name it does not know stays out
