"""The live separation monitor's judgement (ground/separation_monitor.py), fed drone telemetry as
it arrives from the broker; the broker path itself is in
tests/integration/planner/test_separation_live.py."""

from __future__ import annotations

import math

import orjson
import pytest

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground import separation_monitor as sm
from dronefleet.ground import separation_tracks as st
from dronefleet.ground.courses import Course, breach_along, breach_within, course_to
from dronefleet.ground.separation_monitor import CLEAR_S, SeparationMonitor
from dronefleet.messaging.status import Alarm, Telemetry

ORIGIN = LLA(40.63, -8.659, 10.0)


def test_a_head_on_approach_is_predicted_when_it_will_enter_the_cylinder() -> None:
    # 25 m apart, closing at 10 m/s: inside 5 m after 2 s.
    assert breach_within((25.0, 0.0, 0.0), (-10.0, 0.0, 0.0), 5.0) == pytest.approx(2.0)
    assert breach_within((60.0, 0.0, 0.0), (-10.0, 0.0, 0.0), 5.0) is None  # 5.5 s away


def test_parallel_tracks_8_m_apart_and_a_crossing_4_m_higher_are_not_breaches() -> None:
    assert breach_within((0.0, 8.0, 0.0), (0.0, 0.0, 0.0), 5.0) is None
    assert breach_within((0.0, 8.0, 0.0), (3.0, 0.0, 0.0), 5.0) is None
    assert breach_within((20.0, 0.0, 4.0), (-10.0, 0.0, 0.0), 5.0) is None
    # ... but one descending onto the other's height while closing is.
    assert breach_within((20.0, 0.0, 4.0), (-10.0, 0.0, -1.0), 5.0) == pytest.approx(1.5)


def test_drones_that_stop_at_their_goals_short_of_each_other_are_not_foreseen_meeting() -> None:
    # Head on, 25 m apart at 5 m/s each: on velocities alone inside 5 m after 2 s ...
    north, south = (5.0, 0.0, 0.0), (-5.0, 0.0, 0.0)
    on = breach_along((25.0, 0.0, 0.0), Course(north), Course(south), 3.0)
    assert on == pytest.approx(2.0)
    # ... but each stops at its waypoint after 1 s (15 m apart, then still): no breach.
    assert breach_along((25.0, 0.0, 0.0), Course(north, 1.0), Course(south, 1.0), 3.0) is None
    # Only one stops: the other flies on into it, 15 m later at 5 m/s -> 1 + 2 s.
    one = breach_along((25.0, 0.0, 0.0), Course(north, 1.0), Course(south), 3.5)
    assert one == pytest.approx(3.0)


def test_a_course_heads_for_the_goal_at_the_drones_speed_and_stops_there() -> None:
    # Flying east at 4 m/s, turning for a goal 8 m north and 3 m up while climbing at 1 m/s.
    course = course_to((0.0, 4.0, 1.0), (8.0, 0.0, 3.0))
    assert course.vel == pytest.approx((4.0, 0.0, 1.0))
    assert (course.flat_s, course.climb_s) == pytest.approx((2.0, 3.0))
    assert course.velocity_at(2.5) == pytest.approx((0.0, 0.0, 1.0))
    assert course.later(1.0).flat_s == pytest.approx(1.0)
    # Climbing away from the goal's height: the climb is not expected to stop.
    assert course_to((0.0, 4.0, 1.0), (8.0, 0.0, -3.0)).climb_s == math.inf
    # Hovering: it stays (a goal far away does not make it set off in the forecast).
    assert course_to((0.0, 0.0, 0.0), (100.0, 0.0, 0.0)).velocity_at(0.0) == (0.0, 0.0, 0.0)


class _Clock:
    now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def monitor(monkeypatch: pytest.MonkeyPatch) -> tuple[SeparationMonitor, list[Alarm], _Clock]:
    clock = _Clock()
    monkeypatch.setattr(sm, "monotonic", clock)
    mon = SeparationMonitor("mqtt://127.0.0.1:1", client_id="test-separation")
    sent: list[Alarm] = []

    async def publish(topic: str, message: Alarm, **_: object) -> None:
        assert topic == "ground/separation/alarms"
        sent.append(message)

    monkeypatch.setattr(mon.client, "publish", publish)
    return mon, sent, clock


async def feed(mon: SeparationMonitor, drone: str, n: float, e: float, up: float, **kw) -> None:
    p = ned_to_lla(NED(n, e, -up), ORIGIN)
    fields = {"lat": p.lat, "lon": p.lon, "alt_m": p.alt_m, "in_air": kw.pop("in_air", 1.0)}
    fields |= kw
    payload = orjson.dumps({"drone_id": drone, "vehicle_time_s": 1.0, "fields": fields})
    await mon._on_telemetry(f"{drone}/telemetry/out", payload)


async def test_two_drones_closing_raise_one_warning_then_one_critical_per_encounter(
    monitor,
) -> None:
    mon, sent, clock = monitor
    # A flies east at 10 m/s towards B, hovering 40 m ahead at the same height.
    await feed(mon, "B", 0, 40, 10)
    for step in range(8):
        clock.now += 0.5
        await feed(mon, "A", 0, 5.0 * step, 10, ve=10.0)
    levels = [a.level.value for a in sent]
    assert levels == ["WARNING", "CRITICAL"]
    warning, critical = sent
    assert warning.drone_id == "A" and warning.reading and warning.reading["other_drone"] == "B"
    assert critical.reading and critical.reading["horizontal_m"] < 5.0
    status = mon.status()
    assert (status.predicted_breaches, status.actual_breaches) == (1, 1)
    assert status.active == ["A/B"]
    assert status.min_horizontal_m is not None and status.min_horizontal_m < 5.0
    # Apart again, long enough: the encounter ends; a new approach is a new encounter.
    await feed(mon, "A", 0, -100, 10)
    clock.now += CLEAR_S + 0.1
    await feed(mon, "A", 0, -100, 10)
    assert mon.status().active == []
    await feed(mon, "B", 0, 40, 10)  # heard again (its last position was getting stale)
    await feed(mon, "A", 0, 38, 10)
    assert mon.status().actual_breaches == 2 and len(sent) == 3


async def test_drones_on_the_ground_3_m_apart_and_layered_drones_are_left_alone(monitor) -> None:
    mon, sent, _ = monitor
    await feed(mon, "A", 0, 0, 0, in_air=0.0)
    await feed(mon, "B", 0, 3, 0, in_air=0.0)
    await feed(mon, "C", 0, 20, 10)
    await feed(mon, "D", 0, 20, 14)  # right above C, 4 m higher
    assert sent == []
    status = mon.status()
    assert status.min_distance_m == pytest.approx(4.0, abs=0.05)
    assert status.min_horizontal_m is None  # never within 3 m of height
    assert math.isclose(status.horizontal_m, 5.0) and status.pairs_compared == 1


async def test_a_drone_not_heard_for_a_while_is_not_compared(monitor) -> None:
    mon, sent, clock = monitor
    await feed(mon, "A", 0, 0, 10)
    clock.now += sm.STALE_S + 1
    await feed(mon, "B", 0, 1, 10)
    assert sent == [] and mon.status().pairs_compared == 0


async def test_a_drone_stopping_at_its_waypoint_short_of_another_raises_nothing(monitor) -> None:
    mon, sent, _ = monitor
    # A flies east at 10 m/s towards B, hovering 25 m ahead; A's waypoint is 10 m on.
    await feed(mon, "B", 0, 25, 10)
    await feed(mon, "A", 0, 0, 10, ve=10.0, **goal(0, 10, 10))
    assert sent == []
    # A goal past B: it is foreseen, as it is without a goal.
    await feed(mon, "A", 0, 0, 10, ve=10.0, **goal(0, 40, 10))
    assert [a.level.value for a in sent] == ["WARNING"]


async def test_a_drone_turning_for_its_next_waypoint_is_foreseen_going_there(monitor) -> None:
    mon, sent, _ = monitor
    # A still flies north at 5 m/s, but its goal is now 15 m east, where B hovers: ahead on
    # its velocity there is nothing; on its course, B (within 5 m after 2 s).
    await feed(mon, "B", 0, 15, 10)
    await feed(mon, "A", 0, 0, 10, vn=5.0)
    assert sent == []
    await feed(mon, "A", 0, 0, 10, vn=5.0, **goal(0, 15, 10))
    assert [a.level.value for a in sent] == ["WARNING"]


def goal(n: float, e: float, up: float) -> dict[str, float]:
    p = ned_to_lla(NED(n, e, -up), ORIGIN)
    return {"goal_lat": p.lat, "goal_lon": p.lon, "goal_alt_m": p.alt_m}


async def test_a_message_is_compared_only_with_the_drones_near_it_whatever_the_fleet(
    monitor,
) -> None:
    """Issue 27: the cost per message is flat in the fleet's size (a neighbour grid)."""
    mon, _, _ = monitor
    compared = []
    for count in (10, 1000):
        for kept in (mon.tracks, mon.grid, mon._partners, mon.encounters):
            kept.clear()
        for i in range(count):  # a fleet on a 300 m grid, every drone in the air
            await feed(mon, f"D{i}", 300.0 * (i // 40), 300.0 * (i % 40), 20)
        before = mon.status().pairs_compared
        await feed(mon, "NEW", 2.0, 2.0, 20)  # beside D0, the others 300 m and more away
        compared.append(mon.status().pairs_compared - before)
    assert compared[0] == compared[1] and 1 <= compared[1] <= 4, compared


async def test_neighbours_across_the_antimeridian_are_found(monitor) -> None:
    mon, sent, _ = monitor
    west = {"drone_id": "W", "vehicle_time_s": 1.0,
            "fields": {"lat": -16.5, "lon": 179.99999, "alt_m": 20.0, "in_air": 1.0}}  # fmt: skip
    east = {"drone_id": "E", "vehicle_time_s": 1.0,
            "fields": {"lat": -16.5, "lon": -179.99999, "alt_m": 20.0, "in_air": 1.0}}  # fmt: skip
    await mon._on_telemetry("W/telemetry/out", orjson.dumps(west))
    await mon._on_telemetry("E/telemetry/out", orjson.dumps(east))
    assert [a.level.value for a in sent] == ["CRITICAL"]  # about 2 m apart


async def test_an_encounter_ends_when_the_pair_has_drifted_beyond_the_grid(monitor) -> None:
    mon, _, clock = monitor
    await feed(mon, "A", 0, 0, 10)
    await feed(mon, "B", 0, 3, 10)
    assert mon.status().active == ["A/B"]
    await feed(mon, "B", 0, 2000, 10)  # far beyond the 27 cubes around A
    clock.now += CLEAR_S + 0.1
    await feed(mon, "A", 0, 0, 10)
    assert mon.status().active == []


async def test_a_crowd_on_the_ground_is_not_compared_and_a_landing_ends_its_encounter(
    monitor,
) -> None:
    """Issue 27: a fleet waiting at its homes (36 drones a grid cube in bench/sim_scale.py) cost
    every message a walk over all of them; only drones in the air are compared now."""
    mon, sent, clock = monitor
    for i in range(200):  # 200 drones on the ground, 1 m apart
        await feed(mon, f"G{i}", float(i // 20), float(i % 20), 0, in_air=0.0)
    assert mon._near("G0") == set() and mon.status().pairs_compared == 0
    await feed(mon, "A", 5, 5, 10)  # in the air above them
    await feed(mon, "B", 5, 8, 10)  # 3 m beside A
    assert mon._near("A") == {"B"}
    assert [a.level.value for a in sent] == ["CRITICAL"] and mon.status().active == ["A/B"]
    await feed(mon, "B", 5, 8, 0, in_air=0.0)  # B lands: A is still compared with it, to end it
    assert mon._near("B") == {"A"}
    clock.now += CLEAR_S + 0.1
    await feed(mon, "A", 5, 5, 10)
    assert mon.status().active == [] and mon._near("A") == set()


def test_pairs_left_out_as_out_of_reach_never_breach_on_their_courses() -> None:
    """The monitor skips the courses of a pair farther apart than their speeds can close in the
    horizon (issue 27): over random pairs, none skipped is one the courses would foresee, and
    the skip is not vacuous."""
    import random

    rng = random.Random(27)
    monitor = SeparationMonitor("local://bus-reach", client_id="x")
    horizon = monitor.horizon_s
    skipped = 0
    for _ in range(20_000):
        tracks = []
        for _ in range(2):
            fields = {"lat": 40.0 + rng.uniform(-4e-4, 4e-4),
                      "lon": -8.0 + rng.uniform(-5e-4, 5e-4), "alt_m": rng.uniform(20, 40),
                      "vn": rng.uniform(-15, 15), "ve": rng.uniform(-15, 15),
                      "vd": rng.uniform(-4, 4), "in_air": 1.0}  # fmt: skip
            if rng.random() < 0.5:
                fields.update(goal_lat=fields["lat"] + rng.uniform(-3e-4, 3e-4),
                              goal_lon=fields["lon"] + rng.uniform(-3e-4, 3e-4),
                              goal_alt_m=rng.uniform(20, 40))  # fmt: skip
            msg = Telemetry(drone_id="QUAD_1", vehicle_time_s=1.0, fields=fields)
            track = st.track_of(msg, 0.0)
            assert track is not None
            tracks.append(track)
        a, b = tracks
        rel = st.relative(a, b, 0.0)
        flat = math.hypot(rel[0], rel[1])
        if st.out_of_reach(a, b, flat, rel[2], horizon):
            skipped += 1
            assert monitor._foreseen(a, b, rel, 0.0) is None, (a, b)
    assert 1_000 < skipped < 19_000
