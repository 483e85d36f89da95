"""Early replacement (beyond the seed): launch the replacement before the battery runs out.

After each step a drone reports, its remaining work is costed against its battery (the vehicle
model's energy estimate). If it cannot finish with the reserve left, the planner finds the last
waypoint unit it can finish, picks the replacement, and launches it when the replacement's
preparation and transit take as long as the old drone's remaining share (its way home not
counted), or would take longer by the next check (the old drone's next waypoint): the new drone
arrives as the old one leaves, or a little before, and the handover gap is near zero instead of
arming + climb + transit.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.deconflict import Share
from dronefleet.ground.planner.ends import GO_HOME, EndAction, end_steps
from dronefleet.ground.planner.estimate import can_finish, drone_model, estimate, fleet_draws
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.legs import mission_altitude, preparation
from dronefleet.ground.planner.models import (
    Handover,
    HandoverKind,
    LatLon,
    Leg,
    LegState,
    MissionRecord,
    MissionState,
)
from dronefleet.ground.planner.ops import PlannerOps
from dronefleet.ground.planner.options import LegRole
from dronefleet.ground.planner.replacement import camera_state, pick
from dronefleet.ground.planner.separation import SeparationConflict
from dronefleet.ground.planner.traffic import keep_apart
from dronefleet.ground.planner.units import remaining, units
from dronefleet.messaging.commands import Command

log = logging.getLogger(__name__)

#: Launch this many vehicle seconds before the computed moment. Arriving early costs nothing but
#: a little overlap (the replacement approaches 3 m above the work and is kept clear of the drone
#: it relieves); arriving late is the gap this module exists to close. Measured on ArduPilot SITL
#: (tests/integration/sitl/test_early_replacement_on_ardupilot.py, beside two busy loops): the
#: tired copter's last waypoints came up to 2.8 s sooner than estimated (estimated from a hover,
#: it was already under way), the relief's take-off and transit took up to 1.6 s longer, and
#: placing and sending the legs after the decision took up to 0.3 wall s (3 vehicle s at SITL's
#: 10x); the worker's own time is measured (:func:`_note_delay`).
LAUNCH_MARGIN_S = 8.0
#: The longest delay of a check counted (vehicle s): a ground stalled once does not make every
#: later relief leave a minute early.
MAX_CHECK_DELAY_S = 30.0


async def check(planner: PlannerOps, record: MissionRecord, leg: Leg) -> None:
    """Check ``leg`` after a step report, and once more for steps reported meanwhile: a check
    takes several vehicle seconds on a loaded host (0.8 wall s, 8 at SITL's 10x), longer than
    a short leg between two survey rows, and a report skipped left the next decision a whole
    unit late."""
    try:
        while True:
            planner.check_again.discard(leg.leg_id)
            await _check(planner, record, leg)
            if leg.leg_id not in planner.check_again:
                break
    finally:
        planner.checking.discard(leg.leg_id)
        planner.check_again.discard(leg.leg_id)
        if not _watched(record, leg):
            planner.check_delays.pop(leg.leg_id, None)


def _note_delay(planner: PlannerOps, leg: Leg, asked_at: Any) -> None:
    """Keep the longest delay of ``leg``'s checks, in its drone's own vehicle seconds (its
    telemetry's clock when the check began, then when the worker answered). The estimates run in
    the planning worker, which on a loaded host took 0.4-0.8 wall s: 4-8 vehicle s of a SITL
    copter at 10x, or of any drone in a stalled moment. The next decision launches that much
    sooner (:func:`decide`, ``delay_s``)."""
    now = (planner.latest.get(leg.drone_id) or {}).get("vehicle_time_s")
    if not isinstance(asked_at, int | float) or not isinstance(now, int | float):
        return
    delay = min(max(now - asked_at, 0.0), MAX_CHECK_DELAY_S)
    planner.check_delays[leg.leg_id] = max(planner.check_delays.get(leg.leg_id, 0.0), delay)


def _watched(record: MissionRecord, leg: Leg) -> bool:
    """Whether ``leg`` is one early replacement looks after (active, working, not handed over)."""
    if not record.options.early_replacement or record.terminal:
        return False
    if leg.role.outgoing or not leg.active:
        return False
    return not record.handed_over(leg)


def _units_within(groups: list[list[int]], fits: Callable[[list[int]], bool]) -> int:
    """How many leading units of work ``fits`` still accepts (each unit whole)."""
    keep = 0
    for n in range(1, len(groups) + 1):
        if not fits([i for g in groups[:n] for i in g]):
            break
        keep = n
    return keep


async def _check(planner: PlannerOps, record: MissionRecord, leg: Leg) -> None:
    if not _watched(record, leg):
        return
    latest = planner.latest.get(leg.drone_id)
    if latest is None:
        return
    here = LLA(latest["lat"], latest["lon"], latest.get("alt_m", 0.0))
    battery = float(latest["battery_pct"])
    asked_at = latest.get("vehicle_time_s")
    left = remaining(record.work, leg.indices, set(record.done))
    if not left:
        return
    drone = await planner.fleet.drone(leg.drone_id)
    if drone is None:
        return
    fleet = await planner.fleet.drones()
    # Estimates per unit of work and per candidate: CPU work, done by the planning worker.
    decision = await planner.worker.run(
        decide,
        record.work,
        left,
        here,
        drone.home,
        battery,
        planner.reserve_pct,
        fleet,
        planner.busy_drones() | {leg.drone_id},
        record.options.strategy,
        # The way home counts against the battery it keeps; landing where it is, as the seed's
        # did, is left to the reserve (the experiments' figures stay the seed's).
        leaving_steps(record.options.end_action) if record.options.end_action == "rtl" else [],
        drone,
        record.options.wind_mps,
        record.options.wind_from_deg,
        planner.check_delays.get(leg.leg_id, 0.0),
        planner.start_delays.longest(),
    )
    _note_delay(planner, leg, asked_at)
    if decision is None:
        return
    if isinstance(decision, str):
        log.warning(
            "mission %s: %s cannot finish and %s", record.mission_id, leg.drone_id, decision
        )
        return
    chosen, prefix, kept, rest = decision.chosen, decision.prefix, decision.kept, decision.rest
    keep, t_old, t_new, leave_at = decision.keep, decision.t_old, decision.t_new, decision.leave_at
    groups = decision.units
    way_out = leaving_steps(record.options.end_action)
    new_end = end_steps(record.options.end_action, [record.work[i] for i in rest])
    if rest:
        # The newcomer is kept clear of the drone it relieves (its last units, then its way
        # out) and of everyone else; if it cannot be, the handover waits for the next step.
        relieved = Share(
            leg.drone_id, [], [record.work[i] for i in kept], way_out, here, drone.home, True,
            drone.flight,
        )  # fmt: skip
        arriving = Share(
            chosen.drone_id, prefix, [record.work[i] for i in rest], new_end, chosen.position,
            chosen.home, chosen.airborne, chosen.flight,
        )  # fmt: skip
        try:
            (placed,) = await keep_apart(planner, fleet, [arriving], also=[relieved])
        except SeparationConflict as exc:
            log.warning("mission %s: early handover not yet: %s", record.mission_id, exc)
            return
        prefix, new_end = placed.prefix, placed.end
    async with planner.lock:
        # Checked again with the decision, under the lock: an alarm, a lost drone's takeover or
        # an extension may have ended the leg while the worker computed.
        if not leg.active or record.terminal or record.handed_over(leg):
            return
        # Its reports went on arriving while the worker computed: what it flew meanwhile is not
        # flown again (a loaded host's SITL copter reached its next waypoint twice), and a
        # decision it has already flown past is dropped (the next report checks again).
        done = set(record.done)
        if any(i in done for i in rest):
            return
        kept = remaining(record.work, kept, done)  # a unit begun is flown whole
        leg.state = LegState.REPLACED
        leaving = Leg(
            leg_id=planner.next_leg_id(record),
            drone_id=leg.drone_id,
            role=LegRole.LEAVING,
            indices=kept,
            suffix=way_out,
        )
        record.legs.append(leaving)  # sent below, once the whole decision is written
        trigger = camera_state(record, leg)
        if trigger:
            prefix.append({"command": Command.CAMERA_TRIGGER.value, "value": trigger})
        new_leg = Leg(
            leg_id=planner.next_leg_id(record),
            drone_id=chosen.drone_id,
            role=LegRole.REPLACEMENT,
            prefix=prefix,
            indices=rest,
            suffix=new_end,
        )
        handover = Handover(
            kind=HandoverKind.EARLY,
            from_drone=leg.drone_id,
            from_leg=leg.leg_id,
            leaving_leg=leaving.leg_id,
            to_drone=chosen.drone_id if rest else None,
            to_leg=new_leg.leg_id if rest else None,
            reason=f"battery {battery:.1f}% cannot finish {len(groups)} waypoint units; "
            f"leaves after {keep}",
            launch_vehicle_s=latest.get("vehicle_time_s"),
            predicted_old_s=round(t_old, 1),
            predicted_new_s=round(t_new, 1),
            resume_position=LatLon(lat=leave_at[0], lon=leave_at[1]),
            resume_index=rest[0] if rest else None,
            remaining_steps=len(rest),
        )
        record.handovers.append(handover)
        record.state = MissionState.HANDED_OVER
        if rest:
            record.legs.append(new_leg)
        # Written before acting: a ground killed between the two sends finds both legs in the
        # record, and a drone that never got its leg is sent it again (reconcile.forgotten).
        await planner.save(record)
        await planner.send_leg(record, leaving)
        if rest:
            await planner.send_leg(record, new_leg)
    planner.emit("handover", mission_id=record.mission_id, **handover.model_dump(mode="json"))
    log.info(
        "mission %s: early handover %s -> %s", record.mission_id, leg.drone_id, chosen.drone_id
    )


@dataclass(frozen=True)
class Decision:
    """An early handover worked out by :func:`decide`."""

    chosen: DroneView  # the drone taking over
    prefix: list[dict[str, Any]]  # its way there
    kept: list[int]  # indices the leaving drone still flies
    rest: list[int]  # indices handed over
    units: list[list[int]]  # the units of work left
    keep: int  # how many of them it keeps
    t_old: float  # seconds the leaving drone still works (its way home not counted)
    t_new: float  # seconds the new one needs to get there
    leave_at: tuple[float, float]


def leaving_steps(end_action: EndAction) -> list[dict[str, Any]]:
    """How a drone handed over early leaves: home (RTL) when the mission's shares end at home,
    else it lands where it stops, as the seed's did (the experiments keep the seed's end)."""
    if end_action == "rtl":
        return [dict(s) for s in GO_HOME]
    return [{"command": Command.LAND.value}, {"command": Command.WAIT_FOR_FLIGHT.value}]


def decide(
    work: list[dict[str, Any]],
    left: list[int],
    here: LLA,
    home: LLA,
    battery: float,
    reserve_pct: float,
    fleet: list[DroneView],
    busy: set[str],
    strategy: str,
    way_out: list[dict[str, Any]],
    tired: DroneView | None = None,
    wind_mps: float | None = None,
    wind_from_deg: float = 0.0,
    delay_s: float = 0.0,
    start_delay_s: float = 0.0,
) -> Decision | str | None:
    """Whether to hand the rest of ``left`` over now: None (not yet, or no need), a reason why
    nobody can, or the handover. Each drone is estimated as its own vehicle flies (``tired``:
    the drone that cannot finish; estimate.drone_model), in the mission's wind (``wind_mps``
    from ``wind_from_deg``) or its autopilot's. A handover decided now reaches the
    drones ``delay_s`` later (what the checks took, :func:`_note_delay`), and the relief starts
    ``start_delay_s`` after its leg is sent (ground/planner/start_delay.py). Runs in the planning
    worker (ground/planner/worker.py)."""
    draws = fleet_draws([tired.flight if tired else None, *(d.flight for d in fleet)])

    def model_of(drone: DroneView | None) -> Any:
        return drone_model(
            drone.flight if drone else None, draws, reported_wind=drone.wind if drone else None,
            wind_mps=wind_mps, wind_from_deg=wind_from_deg,
        )  # fmt: skip

    model = model_of(tired)

    def cost(indices: list[int], out: list[dict[str, Any]] | None = None) -> Any:
        """What it keeps, then its way ``out`` (``way_out``, by default)."""
        steps = [*(work[i] for i in indices), *(way_out if out is None else out)]
        return estimate(
            steps, start=here, home=home, airborne=True, battery_pct=battery, model=model
        )

    if can_finish(cost(left), reserve_pct=reserve_pct)[0]:
        return None
    groups = units(work, left)
    keep = _units_within(groups, lambda idx: can_finish(cost(idx), reserve_pct=reserve_pct)[0])
    kept = [i for g in groups[:keep] for i in g]
    rest = [i for g in groups[keep:] for i in g]
    # Until it leaves its last waypoint: its way home is no part of the handover (counted in, a
    # drone going home by RTL never seemed near leaving, and the replacement only left once the
    # tired drone could keep nothing: 23 vehicle s without a waypoint on SITL).
    t_old = cost(kept, []).duration_s if kept else 0.0
    # The next check comes with its next waypoint: launched then, would the replacement be late?
    t_next = cost(groups[0], []).duration_s if kept else 0.0
    leave = next(
        (work[i] for i in reversed(kept) if work[i].get("command") == Command.NAVIGATE), None
    )
    leave_at = (leave["lat"], leave["lon"]) if leave else (here.lat, here.lon)
    altitude = mission_altitude(work)
    chosen, prefix = pick(
        reserve_pct, fleet, leave_at, [work[i] for i in rest], altitude, busy, strategy,
        wind_mps, wind_from_deg,
    )  # fmt: skip
    if chosen is None:
        return str(prefix) if keep == 0 else None
    # Approach 3 m above the work so the two drones never share a height at the handover.
    prefix = preparation(chosen, altitude, strategy=strategy, go_to=leave_at, transit_offset_m=3.0)
    t_new = estimate(
        prefix,
        start=chosen.position,
        home=chosen.home,
        airborne=chosen.airborne,
        battery_pct=chosen.battery_pct,
        model=model_of(chosen),
    ).duration_s
    # Not launched now, it would be at the next decision: after the next waypoint's report, or
    # after this check's delay if that is longer (a step reported meanwhile is checked at once
    # after), and that decision takes its delay too. Launch now if that would be late.
    if t_old - max(t_next, delay_s) > t_new + delay_s + start_delay_s + LAUNCH_MARGIN_S:
        return None  # not yet: the next decision is still in time
    return Decision(chosen, prefix, kept, rest, groups, keep, t_old, t_new, leave_at)
