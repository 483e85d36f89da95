"""Creating, checking, previewing and starting missions (REST: ``/api/v1/missions``).

A mission is given as steps (the seed's commands) or as an area (coverage). Before it is accepted
it is checked: no step above the altitude limit, every drone's share inside its geofence
(ground/planner/geofence.py), and every drone's battery must finish its share with the reserve
left (energy estimated from the vehicle model, the way home included, in the wind given or
reported: ground/planner/estimate/). A refused mission changes nothing.

Drones that go home together fly home on return layers of their own (ground/planner/ends.py).
A mission asked to fly on board (``options.onboard`` true) whose share has a step the autopilot
cannot fly is refused naming the step; otherwise each share says who flies it (``flown_by``:
``autopilot`` or ``companion``, and ``companion_reason``), in the preview and on its leg.

Planning runs in the planning worker (ground/planner/plan.py); each drone's share is made and
checked in ground/planner/shares.py (the drones: drone_choice.py; the battery: share_battery.py;
who flies it: flown_by.py).
"""

from __future__ import annotations

import secrets
from collections.abc import Awaitable, Callable
from typing import Any

from pydantic import ValidationError

from dronefleet.errors import Conflict
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.coverage import AreaSpec
from dronefleet.ground.planner.fleet_view import candidates
from dronefleet.ground.planner.mission_spec import MissionSpec
from dronefleet.ground.planner.models import Leg, MissionRecord, MissionState
from dronefleet.ground.planner.options import MissionOptions, RecordOptions, Strategy
from dronefleet.ground.planner.plan import Planned, planned

# re-exported (the tests plan with launch.plan_mission)
from dronefleet.ground.planner.plan import plan_mission as plan_mission
from dronefleet.ground.planner.service import MissionPlanner, PlannerError
from dronefleet.messaging.commands import Command
from dronefleet.messaging.common import reason


async def preview(planner: MissionPlanner, spec: MissionSpec) -> dict[str, Any]:
    done = await planned(planner, spec)
    return {
        "steps": done.work,
        **done.coverage,
        "end_action": spec.options.end_action,
        "drones": [
            {"drone_id": drone_id, "steps": len(prefix) + len(idx) + len(end),
             "end": [s["command"] for s in end], "waypoints": _places(done.work, idx), **est}
            for drone_id, prefix, idx, end, est in done.shares
        ],
    }  # fmt: skip


def _places(work: list[dict[str, Any]], indices: list[int]) -> list[dict[str, float]]:
    """Where a share's work steps fly, in its order: the planner map draws each drone's route
    in the drone's colour, so the split among drones shows before they fly (issue 29)."""
    steps = (work[i] for i in indices)
    return [{"lat": s["lat"], "lon": s["lon"]} for s in steps if "lat" in s and "lon" in s]


#: Called with the request, its plan and the fleet's records before a mission flies; raises to
#: refuse it (the pre-flight checklist, ground/planner/preflight.py).
Gate = Callable[["MissionSpec", Planned, list[dict[str, Any]]], Awaitable[None]]


async def create(
    planner: MissionPlanner, spec: MissionSpec, *, start: bool = False, gate: Gate | None = None
) -> MissionRecord:
    records = await planner.fleet.records()
    done = await planned(planner, spec, records)
    if start and gate is not None:
        await gate(spec, done, records)
    record = MissionRecord(
        mission_id=spec.mission_id or f"M{secrets.token_hex(4)}",
        name=spec.name,
        drones=[drone_id for drone_id, *_ in done.shares],
        area=AreaSpec.model_validate(spec.area.model_dump()) if spec.area else None,
        work=done.work,
        options=RecordOptions(**spec.options.model_dump(), custom_steps=spec.steps is not None),
    )
    await planner.add(record)
    if start:
        await launch(planner, record, done.shares)
    return record


async def launch(planner: MissionPlanner, record: MissionRecord, shares: list[Any]) -> None:
    record.state = MissionState.RUNNING
    for drone_id, prefix, indices, end, est in shares:
        leg = Leg(
            leg_id=planner.next_leg_id(record),
            drone_id=drone_id,
            prefix=prefix,
            indices=indices,
            suffix=end,
            flown_by=est.get("flown_by"),
            companion_reason=est.get("companion_reason"),
        )
        await planner.send_leg(record, leg)


async def start(
    planner: MissionPlanner, mission_id: str, *, gate: Gate | None = None
) -> MissionRecord:
    record = planner.get(mission_id)
    if record.state is not MissionState.PLANNED:
        raise Conflict(f"mission {mission_id} is {record.state.value}, not planned")
    try:
        spec = MissionSpec(
            drones=record.drones,
            steps=record.work if record.options.custom_steps else None,
            area=record.area,
            options=record.options.request(),
        )
    except ValidationError as exc:  # stored before the request bounds were tightened
        raise PlannerError(f"mission {mission_id} can no longer be planned: {reason(exc)}") from exc
    records = await planner.fleet.records()
    done = await planned(planner, spec, records)
    if gate is not None:
        await gate(spec, done, records)
    record.work = done.work
    await launch(planner, record, done.shares)
    return record


async def call_drone(
    planner: MissionPlanner,
    lat: float,
    lon: float,
    *,
    altitude_m: float = 10.0,
    strategy: Strategy = "ours",
) -> MissionRecord:
    """The seed's panic button (5.1): the nearest available drone comes and hovers above you."""
    target = LLA(lat, lon)
    fleet = await planner.fleet.drones()
    pool = candidates(
        fleet, target, exclude=planner.busy_drones(), min_battery_pct=planner.reserve_pct
    )
    if not pool:
        raise Conflict("no drone is available to come")
    spec = MissionSpec(
        name=f"call to {lat:.6f},{lon:.6f}",
        drones=[pool[0].drone_id],
        steps=[
            {
                "command": Command.NAVIGATE.value,
                "lat": lat,
                "lon": lon,
                "altitude_delta": altitude_m,
            },
            {"command": Command.WAIT_FOR_FLIGHT.value},
        ],
        # It comes to stay: a call ends hovering above the caller until an operator sends the
        # drone home (abort) or on.
        options=MissionOptions(strategy=strategy, collaboration=False, end_action="hold"),
    )
    return await create(planner, spec, start=True)
