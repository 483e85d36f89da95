"""The Drone Identifier: fleet from heartbeats and gear, liveness, broker queries, persistence."""

from __future__ import annotations

import pytest

from dronefleet.ground.fleet import DroneRecord, DroneStatus, LenientHeartbeat
from dronefleet.ground.identifier import DroneIdentifier
from dronefleet.ground.manager.gateway import DroneGateway
from dronefleet.ground.state import StateStore
from support.ground_fakes import FakeDrone, eventually

pytestmark = pytest.mark.integration


def hb(drone_id="Q1", interval_s=5.0, vehicle_s=0.0, sent=100.0):
    return LenientHeartbeat.model_validate(
        {
            **FakeDrone("mqtt://x:1", drone_id).heartbeat(),
            "interval_s": interval_s,
            "vehicle_time_s": vehicle_s,
            "timestamp": sent,
            "future": 1,
        }
    )


def test_lost_after_three_declared_intervals_at_the_drones_rate_and_online_on_the_next():
    record = DroneRecord.first(hb(), now=100.0)
    assert record.lost_after_s() == 15.0  # its rate not known yet: 3 x 5 s
    # A 10x sped-up drone: 5 vehicle s between heartbeats, 0.5 s of its wall clock.
    record.observe(hb(vehicle_s=5.0, sent=100.5), now=100.5)
    assert record.clock_rate == pytest.approx(10.0)
    assert record.lost_after_s() == pytest.approx(2.0)  # 3 x 0.5 s is under the 2 s floor
    assert record.lost_after_s(10.0) == pytest.approx(10.0)  # dronefleet ground --lost-after 10
    record.status = DroneStatus.LOST
    assert record.observe(hb(vehicle_s=400.0, sent=140.0), now=140.0) is True  # back
    assert record.status is DroneStatus.ONLINE
    assert record.heartbeat_interval_s == pytest.approx(0.5)  # the outage gap is not a rate


def test_a_drone_that_cannot_reach_its_autopilot_is_shown_so_not_lost():
    record = DroneRecord.first(hb(), now=100.0)
    cut = LenientHeartbeat.model_validate({**hb().model_dump(), "autopilot_link": False})
    record.observe(cut, now=105.0)
    assert record.status is DroneStatus.AUTOPILOT_LINK_LOST
    assert record.public()["status"] == "autopilot link lost"
    record.observe(hb(), now=110.0)
    assert record.status is DroneStatus.ONLINE


async def test_the_fleet_is_kept_and_answered_over_the_broker(broker, tmp_path):
    state = await StateStore(tmp_path / "g.db").open()
    identifier = await DroneIdentifier(broker, state, client_id="id-test").start()
    gateway = await DroneGateway(broker, state, client_id="gw-test").start()
    drone = await FakeDrone(broker, "Q1", interval_s=0.1).start()
    try:
        record = await eventually(lambda: identifier.fleet.get("Q1"))
        await eventually(lambda: record.specs and record.sensors)
        fleet = await gateway.fleet()
        assert fleet[0]["drone_id"] == "Q1" and fleet[0]["specs"]["frame"] == "quad"
        # Liveness uses the drone's rate, read from its stamps: wait until it is known.
        await eventually(lambda: record.heartbeat_interval_s < 1.0)
        await drone.stop()
        await eventually(lambda: record.status is DroneStatus.LOST, timeout_s=4)
    finally:
        await identifier.stop()
        await gateway.stop()
    again = await DroneIdentifier(broker, state, client_id="id-test-2").start()
    try:
        assert again.fleet["Q1"].status is DroneStatus.LOST
        assert again.fleet["Q1"].sensors == {"CO2": {"unit": "ppm"}}
    finally:
        await again.stop()
        await state.close()
