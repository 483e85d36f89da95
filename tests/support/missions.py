"""A small field and a two-drone fleet on the experiments' harness, for the planner's fault tests.

The field (13 x 60 m at 10 m spacing, the seed's grid) has 28 waypoints; QUAD_A flies it and
QUAD_B waits to take over.
"""

from __future__ import annotations

from typing import Any

from dronefleet.experiments import scenarios
from dronefleet.experiments.harness import Harness
from dronefleet.geo.types import NED
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.coverage import AreaSpec, plan_area
from dronefleet.ground.planner.options import MissionOptions


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
