"""The estimate of a list of steps (:func:`estimate`): the steps replayed one by one on the
estimator's vehicle (:class:`._State`), repeated units of a coverage route flown once
(:mod:`.units`), into seconds and mAh per step and the battery left."""

from __future__ import annotations

from typing import Any

from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.estimate.result import Estimate
from dronefleet.ground.planner.estimate.state import _State
from dronefleet.ground.planner.estimate.units import Keys, Replay, Units, fly_unit
from dronefleet.ground.planner.estimate.vehicle import DEFAULT_MODEL, VehicleModel


def estimate(
    steps: list[dict[str, Any]],
    start: LLA,
    home: LLA,
    *,
    airborne: bool,
    battery_pct: float = 100.0,
    model: VehicleModel = DEFAULT_MODEL,
) -> Estimate:
    """Time and battery for a drone at ``start`` (home ``home``) to fly ``steps``.

    An airborne drone is taken to hover at ``start`` (armed, at ``start``'s height above home);
    one on the ground is taken as disarmed unless the steps never arm it.
    """
    here = lla_to_ned(start, home)
    state = _State(model, n=here.n, e=here.e, h=max(0.0, -here.d) if airborne else 0.0)
    if airborne:
        state.armed = state.in_air = True
        state.target, state.target_h = (here.n, here.e), state.h
    elif not any(s.get("command") == "arm" for s in steps):
        state.armed = True  # armed by someone else: do not charge arming it never asked for
    per_step: list[float] = []
    per_step_mah: list[float] = []
    cache: dict[tuple, Replay] = {}  # repeated units, flown once (units.py)
    keys = Keys()
    found = Units(steps, home, keys)
    known: int | None = None  # the state's key part when the last unit was replayed
    i = 0
    while i < len(steps):
        k = found.at.get(i)
        if k is not None:
            unit = found.items[k]
            replay = fly_unit(state, found.targets[k], unit, steps, home, cache, keys, known)
            per_step.extend(replay.seconds)
            per_step_mah.extend(replay.mah)
            known = replay.state_key
            i = unit.end
            continue
        before = state.charge_as
        per_step.append(state.run(steps[i], home))
        per_step_mah.append((state.charge_as - before) / 3.6)
        known = None
        i += 1
    if state.homing and per_step:  # an rtl nobody waits for: the vehicle still flies home
        before = state.charge_as
        per_step[-1] += state.finish_homing()
        per_step_mah[-1] += (state.charge_as - before) / 3.6
    energy = state.charge_as / 3.6
    used = 100.0 * energy / model.capacity_mah
    return Estimate(
        duration_s=sum(per_step),
        energy_mah=energy,
        battery_used_pct=used,
        battery_end_pct=battery_pct - used,
        per_step=per_step,
        per_step_mah=per_step_mah,
        notes=state.notes,
    )
