"""A route's units costed kind by kind (estimate/repeated.py) say what the estimator says of the
whole route's steps, to the bit; a turn is stepped once for a wait_for_flight, not twice."""

from __future__ import annotations

import numpy as np
import pytest

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.coverage import AreaSpec, CoveragePlan, plan_area
from dronefleet.ground.planner.estimate import DEFAULT_MODEL, VehicleModel, estimate
from dronefleet.ground.planner.estimate.motion import _Motion
from dronefleet.ground.planner.estimate.repeated import unit_costs
from dronefleet.vehicle.kinematics import Kinematics

WINDY = DEFAULT_MODEL.with_wind(6.0, 30.0)


def by_estimate(plan: CoveragePlan, model: VehicleModel) -> list[np.ndarray]:
    """The estimator's per-step figures of the whole route, added up per unit."""
    units = [plan.unit_steps(i) for i in range(len(plan.waypoints))]
    ref = LLA(plan.waypoints[0].lat, plan.waypoints[0].lon)
    start = LLA(ref.lat, ref.lon, plan.altitude_m)
    est = estimate([s for u in units for s in u], start, ref, airborne=True, model=model)
    first = np.cumsum([0] + [len(u) for u in units[:-1]])
    leg = np.zeros(len(est.per_step), dtype=bool)
    leg[first] = leg[first + 1] = True
    out = []
    for figures in (np.asarray(est.per_step), np.asarray(est.per_step_mah)):
        out += [np.add.reduceat(np.where(leg, figures, 0.0), first)]
        out += [np.add.reduceat(np.where(leg, 0.0, figures), first)]
    return [out[0], out[1], out[2], out[3]]  # leg s, hold s, leg mAh, hold mAh


def by_kind(plan: CoveragePlan, model: VehicleModel, kinds: list | None = None):
    labels: dict = {}
    kinds = kinds or [(p.kind, p.trigger_m) for p in plan.points]
    kind_of = [labels.setdefault(k, len(labels)) for k in kinds]
    lat = np.array([p.lat for p in plan.waypoints])
    lon = np.array([p.lon for p in plan.waypoints])
    ref = LLA(plan.waypoints[0].lat, plan.waypoints[0].lon)
    start = LLA(ref.lat, ref.lon, plan.altitude_m)
    return unit_costs(kind_of, lat, lon, plan.unit_steps, start, ref, model=model)


@pytest.mark.parametrize("fly", [False, True])
@pytest.mark.parametrize("model", [DEFAULT_MODEL, WINDY], ids=["calm", "windy"])
def test_units_costed_by_kind_are_the_estimators_figures(rect, fly, model):
    action = {"action": "takepic"} if fly else {"action": "read_sensors", "hold_s": 1.5}
    plan = plan_area(AreaSpec(polygon=rect(60, 90), spacing_m=6, fly_through=fly, **action))
    costs = by_kind(plan, model)
    assert costs is not None
    got = [costs.leg_s, costs.hold_s, costs.leg_mah, costs.hold_mah]
    for mine, theirs in zip(got, by_estimate(plan, model), strict=True):
        assert np.array_equal(mine, theirs)  # the same floats, not close ones


def test_a_unit_unlike_its_kind_is_refused(at):
    points = [at(10.0 * i, 0.0) for i in range(4)]
    lat, lon = np.array([p.lat for p in points]), np.array([p.lon for p in points])

    def steps_of(i: int) -> list[dict]:  # every other waypoint takes a picture
        steps = [{"command": "navigate", "lat": lat[i], "lon": lon[i], "altitude_delta": 10.0}]
        return steps + [{"command": "wait_for_flight"}] + [{"command": "takepic"}] * (i % 2)

    start = LLA(points[0].lat, points[0].lon, 10.0)
    assert unit_costs([0, 1, 0, 1], lat, lon, steps_of, start, points[0]) is not None
    with pytest.raises(ValueError, match="not of its kind"):
        unit_costs([0] * 4, lat, lon, steps_of, start, points[0])


def test_units_that_are_not_a_movement_and_holds_are_left_to_the_estimator(at):
    points = [at(10.0 * i, 0.0) for i in range(4)]
    lat, lon = np.array([p.lat for p in points]), np.array([p.lon for p in points])

    def steps_of(i: int) -> list[dict]:
        return [{"command": "takepic"}, {"command": "navigate", "lat": lat[i], "lon": lon[i]}]

    start = LLA(points[0].lat, points[0].lon, 10.0)
    assert unit_costs([0] * 4, lat, lon, steps_of, start, points[0]) is None


def test_a_wait_after_a_turn_flies_the_turn_once_and_says_the_same(rect, monkeypatch):
    plan = plan_area(
        AreaSpec(polygon=rect(60, 90), spacing_m=6, action="takepic", fly_through=True)
    )
    ref = LLA(plan.waypoints[0].lat, plan.waypoints[0].lon)
    start = LLA(ref.lat, ref.lon, plan.altitude_m)
    steps = plan.mission_steps()
    stepped = {"n": 0}
    fly_to = Kinematics.fly_to

    def counted(self, *args, **kwargs):
        stepped["n"] += 1
        return fly_to(self, *args, **kwargs)

    monkeypatch.setattr(Kinematics, "fly_to", counted)
    once = estimate(steps, start, ref, airborne=True, model=WINDY)
    steps_once, stepped["n"] = stepped["n"], 0
    monkeypatch.setattr(_Motion, "_turned", lambda *args: None)  # every turn flown twice
    twice = estimate(steps, start, ref, airborne=True, model=WINDY)
    assert steps_once < 0.8 * stepped["n"]
    assert (once.per_step, once.per_step_mah) == (twice.per_step, twice.per_step_mah)
    assert once.energy_mah == twice.energy_mah
