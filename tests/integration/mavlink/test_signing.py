"""MAVLink 2 signing between the drone controller and the autopilot (issue 12, must-show 5).

The simulated Copter is given a key as ArduPilot is once signing is set up: it signs what it sends
and ignores anything not signed with that key. Our backend with the key flies it; a station
without the key (or with another) still reads its telemetry, but its commands are ignored.
"""

from __future__ import annotations

import asyncio

import pytest
from pymavlink import mavutil

from dronefleet.drone.fc.mavlink import open_flight_controller
from dronefleet.protocols.mavlink.codec import enable_signing, signing_key
from dronefleet.vehicle.base import FcError

pytestmark = pytest.mark.integration

KEY = signing_key("fleet signing passphrase")


def url(endpoint) -> str:
    return f"udpout:127.0.0.1:{endpoint.port}"


async def test_a_signed_link_flies(sim_fleet):
    async with sim_fleet(1, speedup=20, signing_key=KEY) as server:
        endpoint = server.endpoints[0]
        fc = await open_flight_controller(url(endpoint), signing_key=KEY)
        try:
            await fc.arm()
            await fc.takeoff(10)
            deadline = fc.clock.now() + 60
            while fc.position().alt_m - fc.home().alt_m < 9.5:
                assert fc.clock.now() < deadline, "no climb to 10 m"
                await fc.clock.sleep(0.2)
            await fc.land()
            while fc.state().armed:
                assert fc.clock.now() < deadline + 60, "no landing"
                await fc.clock.sleep(0.2)
        finally:
            await fc.close()
        assert endpoint.copter.vehicle.time_s > 10
        assert endpoint.unsigned_dropped == 0  # every frame of ours was signed and fresh


def _station(endpoint, key: bytes | None):
    conn = mavutil.mavlink_connection(url(endpoint), source_system=254, dialect="ardupilotmega")
    conn.mav = mavutil.mavlink.MAVLink(conn, srcSystem=254, srcComponent=190)
    conn.mav.robust_parsing = True
    if key is not None:
        enable_signing(conn.mav, key)
    return conn


@pytest.mark.parametrize(
    "key", [None, signing_key("another passphrase")], ids=["unsigned", "wrong"]
)
async def test_commands_without_the_key_are_ignored(sim_fleet, key):
    async with sim_fleet(1, speedup=20, signing_key=KEY) as server:
        endpoint = server.endpoints[0]
        conn = await asyncio.to_thread(_station, endpoint, key)
        m = mavutil.mavlink
        try:
            conn.mav.heartbeat_send(m.MAV_TYPE_GCS, m.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            beat = await asyncio.to_thread(conn.recv_match, type="HEARTBEAT", blocking=True,
                                           timeout=10 if key is None else 3)  # fmt: skip
            # Telemetry is signed, not encrypted: a station without a key reads it; one with
            # another key drops it as wrongly signed (pymavlink checks what it receives).
            assert (beat is not None) == (key is None)
            for _ in range(3):
                conn.mav.set_mode_send(1, m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4)  # GUIDED
                conn.mav.command_long_send(
                    1, 1, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 21196, 0, 0, 0, 0, 0
                )  # fmt: skip (forced arm)
                conn.mav.command_long_send(1, 1, m.MAV_CMD_NAV_TAKEOFF, 0,
                                           0, 0, 0, 0, 0, 0, 10)  # fmt: skip
                await asyncio.sleep(0.3)
            ack = await asyncio.to_thread(conn.recv_match, type="COMMAND_ACK", blocking=True,
                                          timeout=2)  # fmt: skip
        finally:
            conn.close()
        vehicle = endpoint.copter.vehicle
        assert ack is None  # ignored, not even refused
        assert not vehicle.armed and not vehicle.in_air
        assert endpoint.copter.mode.name != "GUIDED"
        assert endpoint.unsigned_dropped >= 10  # 9 commands and a heartbeat, counted


async def test_our_own_backend_without_the_key_cannot_arm(sim_fleet):
    async with sim_fleet(1, speedup=20, signing_key=KEY) as server:
        endpoint = server.endpoints[0]
        with pytest.raises((FcError, TimeoutError)):
            fc = await open_flight_controller(
                url(endpoint), connect_timeout_s=5, ack_timeout_s=0.5, retries=1
            )
            try:
                await fc.arm()
            finally:
                await fc.close()
        assert not endpoint.copter.vehicle.armed


async def test_signed_sim_and_drone_processes_fly_a_mission(embedded_broker, tmp_path):
    """As deployed: the key in a 0600 file for ``dronefleet sim`` and ``dronefleet drone`` (never
    on the command line), a mission sent over MQTT flown to the end on the signed link."""
    from support.drones import Operator, drone_process

    from .conftest import free_udp_ports
    from .test_sim_process import HOME_ARG, sim_process
    from .test_takeover import line

    key_file = tmp_path / "mavlink.key"
    key_file.write_text("fleet signing passphrase\n")
    key_file.chmod(0o600)
    base = free_udp_ports(1)
    signed = ("--mavlink-signing-key-file", str(key_file))
    async with sim_process(1, base, "--home", HOME_ARG, "--speedup", "10", *signed) as lines:
        assert any("signed" in line for line in lines)
        url = f"udpout:127.0.0.1:{base}"
        async with (
            drone_process(embedded_broker, "QUAD_SIG", "--fc", "mavlink", "--fc-url", url, *signed),
            Operator(embedded_broker) as op,
        ):
            await op.heartbeat("QUAD_SIG")
            await op.send_mission("QUAD_SIG", mission_id="sig", steps=line(2))
            done = await op.wait_for(
                lambda: [p for p in op.progress("sig") if p["event"] in ("completed", "failed")],
                timeout_s=120,
            )
    assert done[0]["event"] == "completed", done
    flown = {p["step_index"] for p in op.progress("sig") if p["event"] == "step"}
    assert flown == set(range(len(line(2))))
