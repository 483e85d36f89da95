"""A small field and a two-drone fleet on the experiments' harness, for the planner's fault tests.

The field (13 x 60 m at 10 m spacing, the seed's grid) has 28 waypoints; QUAD_A flies it and
QUAD_B waits to take over.
"""

from __future__ import annotations

import asyncio
from collections import Counter
from collections.abc import Awaitable, Callable
from typing import Any

from dronefleet.experiments import scenarios
from dronefleet.experiments.harness import ORIGIN, Harness
from dronefleet.geo.types import NED
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.coverage import AreaSpec, plan_area
from dronefleet.ground.planner.estimate import estimate
from dronefleet.ground.planner.models import MissionRecord
from dronefleet.ground.planner.options import MissionOptions
from dronefleet.ground.planner.units import units


def small_field_steps(alarm: str | None = None) -> list[dict[str, Any]]:
    area = AreaSpec(
        polygon=scenarios.rectangle(17, 0, 30, 60),
        spacing_m=10,
        altitude_m=10,
        angle_deg=0,
        grid="seed",
    )
    steps = plan_area(area).mission_steps()
    return scenarios.with_alarm(steps, 13, alarm) if alarm else steps


async def fly_with_a_spare(
    h: Harness,
    steps: list[dict[str, Any]],
    options: MissionOptions,
    *,
    spare_at: NED,
    hovering_m: float | None = None,
) -> str:
    """QUAD_A starts ``steps`` (from the ground or hovering); QUAD_B idles at ``spare_at``."""
    await h.add_drone("QUAD_A", NED(0, 0), hovering_m=hovering_m)
    await h.add_drone("QUAD_B", spare_at)
    await h.wait_identified(["QUAD_A", "QUAD_B"])
    await h.settle()
    spec = launch.MissionSpec(name="faults", drones=["QUAD_A"], steps=steps, options=options)
    record = await launch.create(h.planner, spec, start=True)
    return record.mission_id


async def restart_ground_after(
    h: Harness,
    options: MissionOptions,
    happened: asyncio.Event,
    *,
    turns: int = 0,
    while_down: Callable[[], Awaitable[None]] | None = None,
    wait_s: float = 120,
    ended_s: float = 240,
) -> MissionRecord:
    """QUAD_A, hovering at 10 m, flies the small field and raises a CRITICAL alarm; QUAD_B idles
    at (77, 70) (:func:`fly_with_a_spare`). Once ``happened`` is set (within ``wait_s``) and
    ``turns`` event-loop turns later, the ground is stopped, ``while_down`` runs, and the ground
    is started again. The mission's record once it has ended (within ``ended_s``)."""
    mission_id = await fly_with_a_spare(
        h, small_field_steps("CRITICAL"), options, spare_at=NED(77, 70), hovering_m=10
    )
    async with asyncio.timeout(wait_s):
        await happened.wait()
    for _ in range(turns):
        await asyncio.sleep(0)
    await h.stop_ground()
    if while_down is not None:
        await while_down()
    await h.start_ground()
    return await h.until_ended(mission_id, timeout_s=ended_s)


async def fly_early_handover(h: Harness, options: MissionOptions) -> Any:
    """QUAD_A, hovering at 10 m with battery for about 13 of the field's units and its way home,
    flies the whole field; QUAD_B idles beyond it, so the planner hands the rest over early.
    The record once the mission has ended and the drones had 30 vehicle s more to land."""
    steps = small_field_steps()  # the field lies 17 to 77 m north, 0 to 30 m east
    first13 = [steps[i] for g in units(steps)[:13] for i in g]
    used = estimate(first13, start=ORIGIN, home=ORIGIN, airborne=True).battery_used_pct
    battery = h.planner.reserve_pct + used + 3.0
    await h.add_drone("QUAD_A", NED(0, 0), hovering_m=10, battery_pct=battery)
    await h.add_drone("QUAD_B", NED(77, 70))
    await h.wait_identified(["QUAD_A", "QUAD_B"])
    await h.settle()
    spec = launch.MissionSpec(name="early", drones=["QUAD_A"], steps=steps, options=options)
    record = await launch.create(h.planner, spec, start=True)
    record = await h.until_ended(record.mission_id, timeout_s=300)
    await h.settle(30.0)
    return record


def flown_as_planned(detail: dict[str, Any]) -> None:
    """A mission's REST detail: completed on its primary legs, nothing handed over, every
    waypoint reported flown exactly once (the process tests' end-to-end check)."""
    assert detail["state"] == "completed", (detail["state"], detail["error"])
    assert not detail["handovers"] and not detail.get("takeovers_cancelled"), (
        detail["handovers"],
        detail.get("takeovers_cancelled"),
        [(leg["drone_id"], leg["role"], leg["state"], leg.get("error")) for leg in detail["legs"]],
    )
    assert {leg["role"] for leg in detail["legs"]} == {"primary"}, detail["legs"]
    assert all(leg["state"] == "completed" for leg in detail["legs"]), detail["legs"]
    waypoints = Counter(
        r["index"]
        for leg in detail["legs"]
        for r in leg["reports"]
        if r.get("index") is not None and detail["work"][r["index"]]["command"] == "wait_for_flight"
    )
    assert len(waypoints) == detail["waypoints"] and set(waypoints.values()) == {1}, waypoints
