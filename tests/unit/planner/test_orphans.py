"""Lost drones are traffic (issue 26, item 3; ground/planner/orphans.py): kept clear by a radius
that grows with their drift, in every plan; a replacement flies its steps near one on another
layer and never to its last point."""

from __future__ import annotations

import numpy as np
import pytest

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.deconflict import Share, separate, traffic_paths
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.orphans import (
    DRIFT_CAP_M,
    GOAL_DRIFT_CAP_M,
    MIN_RADIUS_M,
    Orphan,
    of_drone,
)
from dronefleet.ground.planner.separation import (
    VERTICAL_M,
    SeparationConflict,
    closest_approach,
    first_conflict,
)
from dronefleet.ground.planner.traffic import traffic
from dronefleet.ground.planner.trajectory import predict

ORIGIN = LLA(40.63, -8.659, 10.0)
WAIT = {"command": "wait_for_flight"}


def at(n: float, e: float, up: float = 0.0) -> LLA:
    return ned_to_lla(NED(n, e, -up), ORIGIN)


def go(n: float, e: float, up: float = 10.0) -> dict:
    p = at(n, e)
    return {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": up}


def lost(n: float, e: float, up: float = 10.0, **kw) -> Share:
    orphan = Orphan("LOST", at(n, e, up), **kw)
    return Share("LOST", [], [], [], orphan.last, ORIGIN, True, orphan=orphan)


def test_the_keep_out_grows_with_speed_and_time_and_stops_at_its_cap() -> None:
    still = Orphan("A", ORIGIN, speed_mps=0.0, age_s=30.0)
    assert float(still.radius_m()) == MIN_RADIUS_M  # hovering when last heard
    moving = Orphan("A", ORIGIN, speed_mps=2.0, age_s=3.0)
    assert moving.radius_m(np.array([0.0, 2.0, 100.0])) == pytest.approx(
        [MIN_RADIUS_M + 6, MIN_RADIUS_M + 10, MIN_RADIUS_M + DRIFT_CAP_M]
    )
    unknown = Orphan("A", ORIGIN)
    assert float(unknown.radius_m()) == MIN_RADIUS_M + DRIFT_CAP_M
    heading = Orphan("A", ORIGIN, goal=at(30, 0, 10), speed_mps=8.0, age_s=6.0)  # 31.6 m
    assert heading.widest_m == MIN_RADIUS_M + GOAL_DRIFT_CAP_M  # it stops at its goal
    points = heading.points()
    assert len(points) == 17 and lla_to_ned(points[-1], ORIGIN).n == pytest.approx(30, abs=0.01)


def test_its_telemetry_gives_its_position_speed_and_goal() -> None:
    goal = at(20, 5, 12)
    fields = {"lat": 40.6301, "lon": -8.659, "alt_m": 20.0, "vn": 3.0, "ve": 4.0}
    fields |= {"goal_lat": goal.lat, "goal_lon": goal.lon, "goal_alt_m": goal.alt_m}
    orphan = of_drone("A", ORIGIN, telemetry=fields, speed_mps=1.0, age_s=4.0)
    assert orphan.last == LLA(40.6301, -8.659, 20.0)
    assert orphan.speed_mps == 5.0 and orphan.goal == goal and orphan.age_s == 4.0
    assert of_drone("A", ORIGIN, speed_mps=1.0).last == ORIGIN  # no telemetry: the heartbeat


@pytest.mark.parametrize(
    ("east_m", "up_m", "clash"),
    [(MIN_RADIUS_M - 1, 10.0, True), (MIN_RADIUS_M + 1, 10.0, False), (0.0, 13.5, False)],
)
def test_passing_an_orphan_is_a_conflict_within_its_radius_and_height(
    east_m: float, up_m: float, clash: bool
) -> None:
    (orphan,) = traffic_paths([lost(50, 0, speed_mps=0.0, age_s=10.0)], ORIGIN)
    passer = predict(
        "B", [go(0, east_m, up_m), WAIT, go(100, east_m, up_m), WAIT],
        start=at(0, east_m, up_m), home=ORIGIN, airborne=True, origin=ORIGIN,
    )  # fmt: skip
    hit = first_conflict(passer, orphan, origin=ORIGIN)
    assert (hit is not None) is clash
    if hit is not None:
        assert hit.lost == "LOST" and hit.minimum_m == MIN_RADIUS_M
        assert "LOST is lost" in hit.describe()


def test_a_replacement_flies_near_an_orphan_on_another_layer_and_never_to_its_last_point():
    orphan = lost(40, 0, speed_mps=5.0, age_s=8.0)  # hovering where the field's 5th point is
    home = at(-10, 20)
    work = [step for n in range(0, 80, 10) for step in (go(n, 0), WAIT)]
    prefix = [{"command": "arm"}, {"command": "takeoff", "value": 10.0}, go(40, 0), WAIT]
    replacement = Share("B", prefix, work, [{"command": "rtl"}, WAIT], home, home, False)

    with pytest.raises(SeparationConflict, match="LOST is lost"):
        separate([replacement], [orphan], origin=ORIGIN)  # a caller that cannot alter work

    (placed,) = separate([replacement], [orphan], origin=ORIGIN, alter_work=True)
    assert placed.work is not None
    assert not any(s.get("lat") == prefix[2]["lat"] for s in placed.prefix)  # not to its point
    radius = orphan.orphan.widest_m  # type: ignore[union-attr]
    for step in placed.work:
        if step["command"] != "navigate":
            continue
        where = lla_to_ned(LLA(step["lat"], step["lon"]), ORIGIN)
        if abs(where.n - 40) < radius:  # near it: at least 5 m above it
            assert step["altitude_delta"] >= 15.0, step
    assert any(s.get("altitude_delta") == 10.0 for s in placed.work)  # far: the work's height
    assert any("lost drone(s) LOST" in n for n in placed.notes)
    flown = predict(
        "B", [*placed.prefix, *placed.work, *placed.end], start=home, home=home,
        airborne=False, origin=ORIGIN,
    )  # fmt: skip
    (kept,) = traffic_paths([orphan], ORIGIN)
    flat, _ = closest_approach(flown, kept)
    assert flat >= radius  # never within its keep-out while within 3 m of its height
    assert VERTICAL_M == 3.0


def view(drone_id: str, online: bool, state: str = "flying") -> DroneView:
    return DroneView(
        drone_id, online, state, None, at(10, 10, 10), ORIGIN, 80.0,
        seen_ago_s=12.0, ground_speed_mps=0.5,
    )  # fmt: skip


def test_a_drone_in_the_air_not_heard_is_an_orphan_until_it_is_heard_again() -> None:
    shares = traffic(
        [], [view("A", online=False), view("B", online=False, state="disarmed")], set()
    )
    (orphan,) = (s for s in shares if s.orphan is not None)
    assert orphan.drone_id == "A" and orphan.orphan.age_s == 12.0  # type: ignore[union-attr]
    assert orphan.orphan.speed_mps == 0.5  # type: ignore[union-attr]
    heard = traffic([], [view("A", online=True)], set())
    assert [s.orphan for s in heard] == [None]  # hovering traffic, as any drone


@pytest.mark.parametrize("orphan_up", [10.0, 14.0])
def test_a_replacement_on_the_ground_inside_an_orphans_keep_out_leaves_it_low_and_crosses_above(
    orphan_up: float,
) -> None:
    """Chaos seed 114: a drone killed on its way out hovers near the others' homes. Its keep-out
    (its speed unknown: the widest) covers a landed drone's take-off column; before, every plan
    for that drone climbed through the orphan's height inside it and was refused, so the lost
    drone's work was never taken over. Now it lifts off below the orphan, leaves the keep-out
    low, climbs outside it and crosses above it to the work."""
    orphan = lost(5, 12, orphan_up)  # 5 m north of B's home, at or above the work's height
    home = at(0, 24)
    work = [step for n in range(30, 80, 10) for step in (go(n, 0), WAIT)]
    prefix = [{"command": "arm"}, {"command": "takeoff", "value": 10.0}, go(5, 12), WAIT]
    replacement = Share("B", prefix, work, [{"command": "rtl"}, WAIT], home, home, False)
    radius = orphan.orphan.widest_m  # type: ignore[union-attr]
    assert radius >= 30.0  # its home is well inside it

    (placed,) = separate([replacement], [orphan], origin=ORIGIN, alter_work=True)

    flown = predict(
        "B", [*placed.prefix, *(placed.work or work), *placed.end], start=home, home=home,
        airborne=False, origin=ORIGIN,
    )  # fmt: skip
    (kept,) = traffic_paths([orphan], ORIGIN)
    flat, _ = closest_approach(flown, kept)
    assert flat >= radius, placed.prefix  # never within it while within 3 m of its height
    takeoff = next(s for s in placed.prefix if s["command"] == "takeoff")
    assert takeoff["value"] <= orphan_up - 5.0  # lifts off below it
    assert not any(s.get("lat") == prefix[2]["lat"] for s in placed.prefix)  # not to its point
    assert any("lost drone(s) LOST" in n for n in placed.notes)
