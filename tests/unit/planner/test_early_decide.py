"""When early replacement launches the relief (issue 28, item 5), as the planning worker decides
it (``early.decide``), on ArduPilot SITL's figures.

Before: the decision flew the dissertation quad (18 A) whatever the vehicle, counted the tired
drone's way home as work left, and ignored its own delay; on SITL the relief left only once the
tired copter could keep nothing, 23 vehicle s of gap.
"""

from __future__ import annotations

import pytest

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.early import Decision, decide, leaving_steps
from dronefleet.ground.planner.estimate import estimate
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.start_delay import MAX_START_DELAY_S, RECENT, StartDelays

from .test_returns import HOME, SITL_FLIGHT

TIRED = {**SITL_FLIGHT, "flight_current_a": 30.0}  # measured in flight, as SITL's copter draws
ALT_M = 20.0


def row(n: int) -> list[dict]:
    """``n`` waypoints 100 m apart going north, 30 m from home."""
    steps: list[dict] = []
    for i in range(n):
        p = ned_to_lla(NED(30 + 100 * i, 0), HOME)
        steps += [
            {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": ALT_M},
            {"command": "wait_for_flight"},
        ]
    return steps


def relief() -> DroneView:
    near = ned_to_lla(NED(0, 30), HOME)
    home = LLA(near.lat, near.lon, HOME.alt_m)
    return DroneView("FRESH", True, "disarmed", None, home, home, 100.0, flight=dict(SITL_FLIGHT))


def ask(
    battery: float,
    *,
    flight: dict | None = TIRED,
    delay_s: float = 0.0,
    start_delay_s: float = 0.0,
    n: int = 12,
):
    work = row(n)
    here = ned_to_lla(NED(30, 0, -ALT_M), HOME)  # over the first waypoint
    here = LLA(here.lat, here.lon, HOME.alt_m + ALT_M)
    tired = DroneView("TIRED", True, "flying", "M", here, HOME, battery, flight=flight)
    return decide(
        work, list(range(len(work))), here, HOME, battery, 20.0, [relief()], {"TIRED"}, "ours",
        leaving_steps("rtl"), tired, delay_s=delay_s, start_delay_s=start_delay_s,
    )  # fmt: skip


def first_launch(**kwargs) -> tuple[float, Decision]:
    """The highest battery (in 0.5 % steps down from 100) at which the relief is launched."""
    battery = 100.0
    while battery > 20:
        answer = ask(battery, **kwargs)
        if isinstance(answer, Decision):
            return battery, answer
        battery -= 0.5
    raise AssertionError("never launched")


def test_the_tired_drone_is_estimated_as_its_own_vehicle_flies():
    own, _ = first_launch()
    quad, _ = first_launch(flight=None)  # no figures: the dissertation quad's 18 A
    assert own > quad + 5, (own, quad)  # at 30 A the battery runs out sooner: launched sooner


def test_the_relief_arrives_before_the_tired_drone_leaves_and_not_long_before():
    battery, decision = first_launch()
    way_home = estimate(
        [*leaving_steps("rtl")], start=HOME, home=HOME, airborne=True, battery_pct=battery
    ).duration_s
    # t_old is the work it keeps, not its way home after it.
    kept = estimate(
        row(12)[: len(decision.kept)],
        start=ned_to_lla(NED(30, 0, -ALT_M), HOME),
        home=HOME,
        airborne=True,
        battery_pct=battery,
    )
    assert decision.t_old < kept.duration_s + way_home
    assert decision.keep >= 1
    early_by = decision.t_old - decision.t_new
    assert 0 < early_by <= 8.0 + 25.0  # the margin, plus one waypoint's leg at most


def test_a_slow_check_launches_the_relief_sooner():
    quick, _ = first_launch()
    slow, decision = first_launch(delay_s=20.0)
    assert slow > quick, (slow, quick)  # launched with more battery left: earlier
    assert decision.t_old - decision.t_new > 20.0


def test_a_relief_slow_to_start_its_leg_is_launched_sooner():
    # A loaded CI host: the relief SITL copter started 13.7 vehicle s after the decision.
    quick, _ = first_launch()
    slow, decision = first_launch(start_delay_s=14.0)
    assert slow > quick, (slow, quick)
    assert decision.t_old - decision.t_new > 14.0


def test_the_longest_recent_send_to_start_delay_counts():
    delays = StartDelays()
    assert delays.longest() == 0.0
    delays.sent("L1", 100.0)
    delays.started("L1", 102.5)
    delays.sent("L2", 50.0)
    delays.started("L2", 63.7)
    assert delays.longest() == pytest.approx(13.7)
    delays.sent("L3", 500.0)
    delays.started("L3", 3.0)  # its drone restarted: its clock began again
    delays.sent("L4", 0.0)
    delays.started("L4", 3600.0)  # sent to a drone offline an hour: capped
    assert delays.longest() == MAX_START_DELAY_S
    delays.started("NEVER-SENT", 10.0)
    delays.sent("L5", None)  # no telemetry yet: nothing measured
    delays.started("L5", 10.0)
    for n in range(RECENT):  # only the latest legs count
        delays.sent(f"Q{n}", 0.0)
        delays.started(f"Q{n}", 1.0)
    assert delays.longest() == 1.0
