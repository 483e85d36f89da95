"""The fleet's measured draw per airframe is kept in the ground's state (issue 28, item 2).

Before, the draw a vehicle's first flight was estimated with came from the heartbeats of the
drones online at that moment: a restart of the ground, or of the drone that had measured it,
and the next first flight fell back on the conservative 32 A. Now each drone's latest measured
draw is written per (airframe, drone) as plans are made and read back by the next plan.
"""

from __future__ import annotations

from dronefleet.ground.planner import airframe_draws, launch
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.state import StateStore

from .test_returns import HOME, SITL_FLIGHT, spec


def view(drone_id: str, **flight: float) -> DroneView:
    return DroneView(drone_id, True, "disarmed", None, HOME, HOME, 100.0,
                     flight={**SITL_FLIGHT, **flight})  # fmt: skip


def first_flight(draws: dict) -> dict:
    fleet = {"QUAD_1": view("QUAD_1")}
    return launch.plan_mission(spec(), fleet, set(), 20.0, 120.0, draws=draws).shares[0][4]


async def test_a_measured_draw_survives_a_restart_and_serves_the_airframes_first_flights(tmp_path):
    path = tmp_path / "ground.db"
    state = await StateStore(path).open()
    try:
        flown = view("QUAD_2", flight_current_a=29.0)
        other = view("QUAD_3", capacity_mah=5000.0, flight_current_a=12.0)  # another airframe
        await airframe_draws.learn(state, [view("QUAD_1"), flown, other])
    finally:
        await state.close()

    state = await StateStore(path).open()  # the ground restarted
    try:
        # QUAD_2's software restarted too: its heartbeat has no measurement yet. QUAD_4 is of
        # the same airframe but returns higher (RTL_ALT is a setting, not an airframe).
        restarted = view("QUAD_2")
        higher = view("QUAD_4", rtl_alt_m=40.0, flight_current_a=31.0)
        draws = await airframe_draws.learn(state, [view("QUAD_1"), restarted, higher])
    finally:
        await state.close()

    shared = first_flight(draws)
    assert any("30.0 A, measured on 2 drone(s) of its airframe" in n for n in shared["notes"]), (
        shared["notes"]
    )
    alone = first_flight({})
    assert any("not measured yet: 32 A assumed (conservative)" in n for n in alone["notes"])
    assert alone["battery_used_pct"] > shared["battery_used_pct"]
    print(f"first flight: {shared['battery_used_pct']:.1f} % on the airframe's 30 A, "
          f"{alone['battery_used_pct']:.1f} % on the conservative 32 A")  # fmt: skip


async def test_a_new_measurement_replaces_the_drones_old_one(tmp_path):
    state = await StateStore(tmp_path / "ground.db").open()
    try:
        await airframe_draws.learn(state, [view("QUAD_2", flight_current_a=20.0)])
        draws = await airframe_draws.learn(state, [view("QUAD_2", flight_current_a=26.0)])
        rows = await state.load_airframe_draws()
    finally:
        await state.close()
    assert [d for ds in draws.values() for d in ds] == [26.0]
    assert len(rows) == 1


def test_a_drone_that_measured_its_own_draw_is_estimated_on_it_not_its_airframes():
    """The airframe's kept figure is for first flights only: QUAD_1 measured 26 A itself, so
    the 30 A kept for its airframe (another drone's) does not change its estimate."""
    key = next(iter(airframe_draws.measured([view("QUAD_2", flight_current_a=30.0)])))[0]
    draws = {airframe_draws._key_of(key): [30.0]}
    fleet = {"QUAD_1": view("QUAD_1", flight_current_a=26.0)}
    own = launch.plan_mission(spec(), fleet, set(), 20.0, 120.0, draws=draws).shares[0][4]
    alone = launch.plan_mission(spec(), fleet, set(), 20.0, 120.0, draws={}).shares[0][4]
    assert own["battery_used_pct"] == alone["battery_used_pct"]
    assert not any("A assumed" in n or "A, measured on" in n for n in own["notes"]), own["notes"]
    other = first_flight(draws)  # a drone that has not flown: the airframe's 30 A
    assert other["battery_used_pct"] > own["battery_used_pct"]
