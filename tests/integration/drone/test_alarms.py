"""Fail-safe alarms from a flying drone: exactly one per crossing.

Issue 2, must-show 4: a long mission drains the battery and exactly one CRITICAL alarm is published
when it crosses the threshold; a gas plume on the path gives exactly one OUT_MEASURE alarm.
"""

from __future__ import annotations

import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.simfleet import SimFleet
from support.drones import Operator

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)


def back_and_forth(legs: int, length_m: float) -> list[dict]:
    steps: list[dict] = [
        {"command": "arm"},
        {"command": "takeoff", "value": 10},
        {"command": "wait_for_flight"},
    ]
    for i in range(legs):
        wp = ned_to_lla(NED(length_m if i % 2 == 0 else 0, 0), HOME)
        steps += [
            {"command": "navigate", "lat": wp.lat, "lon": wp.lon, "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]
    return steps


async def test_draining_battery_raises_exactly_one_critical_alarm(embedded_broker):
    async with SimFleet(speedup=50) as fleet, Operator(embedded_broker) as op:
        await fleet.add_drone(
            DroneConfig(drone_id="QUAD_LOW", battery_critical_pct=20.0),
            embedded_broker,
            home=HOME,
            battery_pct=24.0,
        )
        await op.send_mission("QUAD_LOW", mission_id="long", steps=back_and_forth(40, 200))
        await op.wait_for(lambda: op.alarms("CRITICAL"), timeout_s=120, key="alarms/out")
        vehicle = fleet.world.vehicles["QUAD_LOW"]
        crossed_at = vehicle.battery_state.remaining_pct
        # Keep flying well past the threshold: no second alarm may come.
        await fleet.clock.sleep(60)
        alarms = op.alarms("CRITICAL")
        assert len(alarms) == 1, alarms
        assert alarms[0]["drone_id"] == "QUAD_LOW"
        assert "20" in alarms[0]["message"]
        assert alarms[0]["mission_id"] == "long"
        assert 15.0 < crossed_at <= 20.0
        assert vehicle.battery_state.remaining_pct < crossed_at


async def test_gas_plume_on_the_path_raises_exactly_one_out_measure_alarm(embedded_broker):
    plume = ned_to_lla(NED(60, 0), HOME)
    async with SimFleet(speedup=30, plumes=[(plume.lat, plume.lon, 3000.0, 12.0)]) as fleet:
        async with Operator(embedded_broker) as op:
            await fleet.add_drone(
                DroneConfig(drone_id="QUAD_GAS", sensor_bounds={"co2_ppm": (None, 1000.0)}),
                embedded_broker,
                home=HOME,
            )
            mission = [*back_and_forth(1, 120), {"command": "sleep", "value": 5}]
            await op.send_mission("QUAD_GAS", mission_id="gas", steps=mission)
            await op.wait_for(
                lambda: [p for p in op.progress("gas") if p["event"] == "completed"], timeout_s=90
            )
            alarms = op.alarms("OUT_MEASURE")
            assert len(alarms) == 1, alarms
            alarm = alarms[0]
            assert alarm["reading"]["value"] > 1000.0
            assert alarm["reading"]["field"] == "co2_ppm"
            north = (alarm["position"]["lat"] - HOME.lat) * 111_000
            assert 40 < north < 80  # raised near the plume, not elsewhere
            assert not op.alarms("CRITICAL")


async def test_forged_telemetry_on_the_drones_topic_raises_no_alarm(embedded_broker):
    """Issue 12: the fail-safe reads the autopilot, not its own telemetry echoed by the broker
    (5 forged messages with battery 3 % made a drone raise 3 genuine CRITICAL alarms)."""
    async with SimFleet(speedup=20) as fleet, Operator(embedded_broker) as op:
        app = await fleet.add_drone(DroneConfig(drone_id="QUAD_SAFE"), embedded_broker, home=HOME)
        await op.heartbeat("QUAD_SAFE")
        forged = {"drone_id": "QUAD_SAFE", "vehicle_time_s": 1.0,
                  "fields": {"battery_pct": 3.0, "lat": HOME.lat, "lon": HOME.lon, "alt_m": 10.0,
                             "co2_ppm": 5000.0}}  # fmt: skip
        for _ in range(5):
            await op.client.publish("QUAD_SAFE/telemetry/out", forged, qos=1)
        await fleet.clock.sleep(5.0)
        assert op.alarms("CRITICAL") == [] and op.alarms("OUT_MEASURE") == []
        assert app.failsafe.alarms_raised == 0
