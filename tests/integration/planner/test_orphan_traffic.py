"""A lost drone is traffic until it is heard again (issue 26, item 3), in one process on virtual
time.

QUAD_A flies the small field; mid-share its drone software is killed (nothing more is heard from
it or sent by it; its vehicle flies on to the goal it was given and hovers there). QUAD_B takes
its work over. Before, the replacement was sent to exactly the orphan's last point (on SITL it
passed 0.23 m from it at the same height); now it keeps 10 m from it horizontally whenever it is
within 3 m of its height, sampled from both vehicles every 0.1 vehicle s, and the mission still
completes with every waypoint flown once. Heard again, the orphan is traffic no more.
"""

from __future__ import annotations

import asyncio
import math
from typing import Any

import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.experiments.harness import ORIGIN, Harness
from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import NED
from dronefleet.ground.planner import traffic as traffic_module
from dronefleet.ground.planner.models import LegRole, MissionState
from dronefleet.ground.planner.options import MissionOptions
from dronefleet.messaging.broker_users import BrokerRole
from dronefleet.sim.flight_controller import SimFlightController
from support.missions import fly_with_a_spare, small_field_steps

from .test_takeover_once import assert_each_waypoint_once

pytestmark = [pytest.mark.integration, pytest.mark.virtual_time]

OPTIONS = MissionOptions(strategy="ours", collaboration=False, early_replacement=False)


async def kill(h: Harness, drone_id: str) -> None:
    """Its drone software dies at once: its broker links drop first (so not a report more goes
    out), then its tasks stop; its vehicle is left flying where it was told, then hovering."""
    app = h.fleet.apps.pop(drone_id)
    for client in app.clients.values():
        await client.stop()
    await app.stop()


async def revive(h: Harness, drone_id: str) -> None:
    """The drone software starts again on the same vehicle (it is heard again)."""
    vehicle = h.fleet.vehicle(drone_id)
    await h.fleet.launch(
        DroneConfig(drone_id=drone_id, heartbeat_interval_s=1.0),
        SimFlightController(vehicle, h.clock),
        h.broker.url_for(drone_id, BrokerRole.DRONE),
        sensors={},
        camera=None,
    )


class Closest:
    """The closest two vehicles come horizontally while within 3 m vertically, sampled."""

    def __init__(self, h: Harness, a: str, b: str) -> None:
        self.h, self.a, self.b = h, a, b
        self.horizontal_m = math.inf
        self.at: dict[str, Any] = {}

    async def run(self) -> None:
        va, vb = self.h.fleet.vehicle(self.a), self.h.fleet.vehicle(self.b)
        while True:
            if va.in_air and vb.in_air:
                pa = lla_to_ned(va.position_lla, ORIGIN)
                pb = lla_to_ned(vb.position_lla, ORIGIN)
                flat, up = math.hypot(pa.n - pb.n, pa.e - pb.e), abs(pa.d - pb.d)
                if up < 3.0 and flat < self.horizontal_m:
                    self.horizontal_m = flat
                    self.at = {"t": self.h.clock.now(), "vertical_m": up, "a": pa, "b": pb}
            await self.h.clock.sleep(0.1)


def orphans_in_traffic(h: Harness, fleet: list[Any]) -> set[str]:
    shares = traffic_module.traffic(
        h.planner.missions.values(), fleet, exclude=set(), latest=h.planner.latest
    )
    return {s.drone_id for s in shares if s.orphan is not None}


async def test_a_killed_drones_replacement_keeps_clear_of_it_until_it_is_heard_again():
    async with Harness(speedup=10) as h:
        mission_id = await fly_with_a_spare(h, small_field_steps(), OPTIONS, spare_at=NED(10, 10))
        while len(h.planner.missions[mission_id].done) < 12:
            await asyncio.sleep(0.05)
        closest = Closest(h, "QUAD_A", "QUAD_B")
        sampling = asyncio.create_task(closest.run())
        await kill(h, "QUAD_A")  # mid-share, flying to its next waypoint
        record = await h.until_ended(mission_id, timeout_s=400)
        orphaned = orphans_in_traffic(h, await h.planner.fleet.drones())
        sampling.cancel()

        await revive(h, "QUAD_A")
        for _ in range(200):
            if "QUAD_A" not in h.planner.lost:
                break
            await asyncio.sleep(0.1)
        heard = orphans_in_traffic(h, await h.planner.fleet.drones())

    print("closest approach", round(closest.horizontal_m, 2), closest.at)
    assert record.state is MissionState.COMPLETED, record.error
    taken = next(leg for leg in record.legs if leg.role is LegRole.REPLACEMENT)
    assert taken.drone_id == "QUAD_B"
    assert taken.altered, "no step was moved off the lost drone's height"
    assert_each_waypoint_once(record)
    assert closest.horizontal_m >= 10.0, closest.at
    assert orphaned == {"QUAD_A"}  # still lost when the mission ended: still traffic
    assert "QUAD_A" not in heard  # heard again: traffic as any drone (its way home), no orphan
