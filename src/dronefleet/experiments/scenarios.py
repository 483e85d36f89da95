"""The seed's four experiments (chapter 5), same geometry, through the real components.

- panic: a caller 100 m from a disarmed drone on the ground presses "Call drone" (5.1);
- survey: 32 x 64 m photographed at 8 m spacing, 45 photos, the drone hovering nearby (5.2);
- replacement: 28 waypoints at 10 m, a CRITICAL alarm at waypoint 13, the replacement on the
  ground 40 m away (5.3);
- collab: 28 x 35 m at 7 m with 2 s holds, an OUT_MEASURE alarm at waypoint 15, three drones on
  the ground (5.4).

``strategy="seed"`` flies the dissertation's way (stop at every photo; take off, then fly; equal
waypoint counts; grid rebuild); ``"ours"`` flies through, climbs while flying, balances the split.
Both end each share as the seed's missions did, hovering where the work ended
(``end_action="hold"``), so the figures measure the work the seed measured; a mission planned
from the API or the web app goes home at the end by default (ground/planner/ends.py).
"""

from __future__ import annotations

from typing import Any

from dronefleet.errors import Failed
from dronefleet.experiments.harness import ORIGIN, Harness
from dronefleet.experiments.report import Result
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import NED
from dronefleet.ground.planner import launch
from dronefleet.ground.planner.coverage import AreaSpec
from dronefleet.ground.planner.coverage.spec import Action, Grid
from dronefleet.ground.planner.ends import EndAction
from dronefleet.ground.planner.mission_spec import MissionSpec
from dronefleet.ground.planner.models import Leg, MissionRecord
from dronefleet.ground.planner.options import MissionOptions, Strategy
from dronefleet.ground.planner.units import units

#: How the experiments' shares end: as the seed's did (see the module's docstring).
SEED_END: EndAction = "hold"


def rectangle(
    north_m: float, east_m: float, width_e_m: float, length_n_m: float
) -> list[tuple[float, float]]:
    """Corners [lat, lon] of a rectangle whose south-west corner is ``north_m``/``east_m`` away."""
    corners = [(0, 0), (length_n_m, 0), (length_n_m, width_e_m), (0, width_e_m)]
    return [
        (p.lat, p.lon)
        for p in (ned_to_lla(NED(north_m + n, east_m + e), ORIGIN) for n, e in corners)
    ]


def _leg(record: MissionRecord, leg_id: str | None) -> Leg:
    leg = record.leg(leg_id) if leg_id else None
    if leg is None:
        raise ExperimentFailed(f"mission {record.mission_id} has no leg {leg_id}")
    return leg


def reports(record: MissionRecord) -> list[tuple[str, Any]]:
    return [(leg.drone_id, r) for leg in record.legs for r in leg.reports]


def reached(record: MissionRecord) -> tuple[int, int]:
    required = set(record.required_indices())
    waits = [
        i for i, s in enumerate(record.work) if s["command"] == "wait_for_flight" and i in required
    ]
    return len(waits), sum(1 for i in waits if i in record.done)


async def panic(h: Harness, strategy: Strategy) -> Result:
    await h.add_drone("QUAD_P", NED(100, 0))
    await h.wait_identified(["QUAD_P"])
    await h.settle()
    t_call = h.clock.now()
    record = await launch.call_drone(
        h.planner, ORIGIN.lat, ORIGIN.lon, altitude_m=10, strategy=strategy
    )
    record = await h.until_ended(record.mission_id)
    leg = record.legs[0]
    by = {r.drone_step: r for r in leg.reports}
    stages = {"request to mission accepted": (leg.started_vehicle_s or t_call) - t_call}
    stages["arming"] = by[0].duration_s or 0.0
    if strategy == "seed":
        stages["vertical flight (climb to 10 m)"] = by[2].duration_s or 0.0
        stages["horizontal flight (100 m)"] = by[4].duration_s or 0.0
    else:
        stages["climbing while flying (100 m)"] = by[max(by)].duration_s or 0.0
    end = max(r.vehicle_time_s or 0.0 for r in leg.reports)
    planned, done = reached(record)
    return Result(
        "panic", strategy, end - t_call, stages, planned, done, mission_id=record.mission_id
    )


async def survey(h: Harness, strategy: Strategy) -> Result:
    await h.add_drone("QUAD_S", NED(0, 0), hovering_m=10)
    await h.wait_identified(["QUAD_S"])
    await h.settle()
    area = AreaSpec(
        polygon=rectangle(60, 0, 32, 64),
        spacing_m=8,
        altitude_m=10,
        angle_deg=0,
        action=Action.TAKEPIC,
        fly_through=strategy == "ours",
        grid=Grid.SEED,
    )
    spec = MissionSpec(
        name="survey",
        drones=["QUAD_S"],
        area=area,
        options=MissionOptions(strategy=strategy, collaboration=False, end_action=SEED_END),
    )
    record = await launch.create(h.planner, spec, start=True)
    record = await h.until_ended(record.mission_id)
    leg = record.legs[0]
    t0 = leg.started_vehicle_s or 0.0
    first_wait = next(r for r in leg.reports if r.command == "wait_for_flight")
    stages = {"to the first waypoint": (first_wait.vehicle_time_s or t0) - t0}
    stages["photographing the area"] = (leg.ended_vehicle_s or t0) - (
        first_wait.vehicle_time_s or t0
    )
    planned, done = reached(record)
    pictures = sum(1 for _, r in reports(record) if r.command == "takepic")
    completed = [d for e, d in h.events if e == "progress" and d.get("event") == "completed"]
    triggered = (completed[-1].get("result") or {}).get("triggered_pictures", 0) if completed else 0
    return Result(
        "survey",
        strategy,
        (leg.ended_vehicle_s or t0) - t0,
        stages,
        planned,
        done,
        mission_id=record.mission_id,
        notes={"pictures": pictures + triggered},
    )


def with_alarm(
    steps: list[dict[str, Any]], after_waypoint: int, level: str
) -> list[dict[str, Any]]:
    """The steps with a virtual alarm after the ``after_waypoint``-th waypoint unit (1-based)."""
    groups = units(steps)
    cut = groups[after_waypoint - 1][-1] + 1
    alarm = {
        "command": "virtualalarm",
        "level": level,
        "message": f"{level} at waypoint {after_waypoint}",
    }
    return [*steps[:cut], alarm, *steps[cut:]]


async def replacement(h: Harness, strategy: Strategy) -> Result:
    """Seed: a virtual CRITICAL alarm at waypoint 13, replaced on alarm. Ours: the first drone's
    battery lasts for 13 waypoints with the 20% reserve; the planner sees it coming and launches
    the replacement early so it arrives as the first drone leaves."""
    from dronefleet.ground.planner.coverage import plan_area
    from dronefleet.ground.planner.estimate import estimate

    area = AreaSpec(
        polygon=rectangle(17, 0, 30, 60), spacing_m=10, altitude_m=10, angle_deg=0, grid=Grid.SEED
    )
    plain = plan_area(area).mission_steps()
    start = ORIGIN
    battery = 100.0
    if strategy == "seed":
        steps = with_alarm(plain, 13, "CRITICAL")
    else:
        steps = plain
        first13 = [plain[i] for g in units(plain)[:13] for i in g]
        used = estimate(first13, start=start, home=start, airborne=True).battery_used_pct
        battery = h.planner.reserve_pct + used + 0.4
    await h.add_drone("QUAD_A", NED(0, 0), hovering_m=10, battery_pct=battery)
    await h.add_drone("QUAD_B", NED(77, 70))  # ~40 m from where the work resumes
    await h.wait_identified(["QUAD_A", "QUAD_B"])
    await h.settle()
    spec = MissionSpec(
        name="replacement",
        drones=["QUAD_A"],
        steps=steps,
        options=MissionOptions(
            strategy=strategy,
            collaboration=False,
            early_replacement=strategy == "ours",
            end_action=SEED_END,
        ),
    )
    record = await launch.create(h.planner, spec, start=True)
    record = await h.until_ended(record.mission_id)
    handover = record.handovers[0]
    second = _leg(record, handover.to_leg)
    t0 = record.legs[0].started_vehicle_s or 0.0
    wait_step = max(i for i, st in enumerate(second.prefix) if st["command"] == "wait_for_flight")
    arrive = next((r.vehicle_time_s or 0.0) for r in second.reports if r.drone_step == wait_step)
    if handover.kind == "early":
        leaving = _leg(record, handover.leaving_leg)
        t_leave = max((r.vehicle_time_s or 0.0) for r in leaving.reports if r.index is not None)
        t_launch = handover.launch_vehicle_s or 0.0
    else:
        t_leave = t_launch = handover.alarm_vehicle_s or 0.0
    waypoints: dict[str, int] = {}
    for leg in record.legs:
        n = sum(
            1
            for r in leg.reports
            if r.index is not None and record.work[r.index]["command"] == "wait_for_flight"
        )
        waypoints[leg.drone_id] = waypoints.get(leg.drone_id, 0) + n
    stages = {
        f"first drone: waypoints 1-{waypoints['QUAD_A']}": t_leave - t0,
        "second drone: preparation and transit": arrive - t_launch,
        "second drone: remaining waypoints": (second.ended_vehicle_s or arrive) - arrive,
    }
    alarms = [a for a in record.alarms if a.level == "CRITICAL"]
    planned, done = reached(record)
    return Result(
        "replacement",
        strategy,
        (second.ended_vehicle_s or 0) - t0,
        stages,
        planned,
        done,
        gap_s=max(0.0, arrive - t_leave),
        mission_id=record.mission_id,
        notes={
            "handover": handover.kind,
            "waypoints per drone": waypoints,
            "resumed at step": handover.resume_index,
            "first drone battery at start %": round(battery, 1),
            "CRITICAL alarms": len(alarms),
            "launched before the first drone left (s)": round(t_leave - t_launch, 1),
        },
    )


async def collab(h: Harness, strategy: Strategy) -> Result:
    from dronefleet.ground.planner.coverage import plan_area

    area = AreaSpec(
        polygon=rectangle(10, 0, 28, 35),
        spacing_m=7,
        altitude_m=10,
        angle_deg=0,
        action=Action.READ_SENSORS,
        hold_s=2,
        grid=Grid.SEED,
    )
    steps = with_alarm(plan_area(area).mission_steps(), 15, "OUT_MEASURE")
    for name, offset in (("QUAD_A", NED(0, 0)), ("QUAD_B", NED(0, 12)), ("QUAD_C", NED(0, 24))):
        await h.add_drone(name, offset)
    await h.wait_identified(["QUAD_A", "QUAD_B", "QUAD_C"])
    await h.settle()
    spec = MissionSpec(
        name="collaborative sensing",
        drones=["QUAD_A"],
        steps=steps,
        area=area,
        options=MissionOptions(strategy=strategy, replacement=False, end_action=SEED_END),
    )
    record = await launch.create(h.planner, spec, start=True)
    record = await h.until_ended(record.mission_id)
    if not record.expansions:
        raise ExperimentFailed(
            f"the OUT_MEASURE alarm did not grow the area (mission {record.state.value})"
        )
    expansion = record.expansions[0]
    t_alarm = expansion.alarm_vehicle_s or 0.0
    first = record.legs[0]
    t0 = first.started_vehicle_s or 0.0
    end = max((r.vehicle_time_s or 0) for _, r in reports(record))
    legs_after = [leg for leg in record.legs[1:] if leg.role in ("primary", "collaborator")]
    stages = {"first drone until the alarm": t_alarm - t0}
    for leg in legs_after:
        stages[f"{leg.drone_id} ({len(leg.indices)} steps)"] = (
            leg.ended_vehicle_s or end
        ) - t_alarm
    planned, done = reached(record)
    return Result(
        "collab",
        strategy,
        end - t_alarm,
        stages,
        planned,
        done,
        mission_id=record.mission_id,
        notes={
            "area_m2 after expansion": expansion.area_m2,
            "waypoints after expansion": expansion.waypoints,
            "split": expansion.assignments,
        },
    )


SCENARIOS = {"panic": panic, "survey": survey, "replacement": replacement, "collab": collab}


class ExperimentFailed(Failed, RuntimeError):
    """An experiment that did not finish, with the scenario's state in one line."""


def _state(h: Harness) -> str:
    missions = h.planner.missions.values() if h.has_planner else []
    parts = [
        f"{m.mission_id} {m.state.value} {len(m.done)}/{len(m.required_indices())} steps"
        for m in missions
    ]
    return f"at vehicle t={h.clock.now():.1f} s; missions: {', '.join(parts) or 'none'}"


async def run(
    name: str, *, strategy: Strategy = "ours", speedup: float = 10.0, fc: str = "sim"
) -> Result:
    """Run experiment ``name``; ``fc`` picks the flight-controller backend of every drone
    (sim, mavlink, uavtalk, or mixed — see :mod:`dronefleet.experiments.fleets`).

    Raises :class:`ExperimentFailed` with the scenario's state when the run does not finish."""
    async with Harness(speedup=speedup, fc=fc) as h:
        try:
            result = await SCENARIOS[name](h, strategy)
            result.separation = h.separation()
            return result
        except Exception as exc:
            what = str(exc) or type(exc).__name__
            raise ExperimentFailed(f"{name} ({strategy}) failed: {what} ({_state(h)})") from exc
