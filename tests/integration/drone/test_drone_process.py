"""A drone started with the CLI, in its own process, driven over MQTT on real brokers.

Issue 2, must-show 1 and 2: every command of Table 4.2 that moves the vehicle is answered with the
request's id and the vehicle ends where it was asked to be; a 10-waypoint mission completes with
one progress message per step and a JSONL log holding every command and step.
"""

from __future__ import annotations

import asyncio

import pytest

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from support.drones import Operator, drone_process, read_jsonl

pytestmark = pytest.mark.integration

HOME = LLA(40.63, -8.659, 10.0)
HOME_ARG = "40.63,-8.659,10"


async def until_near(op: Operator, drone_id: str, target: NED, tol_m: float = 1.0, timeout_s=60.0):
    """Poll the drone's own position (objrequest over MQTT) until it is within ``tol_m``."""
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while True:
        answer = await op.command(drone_id, command="objrequest", value="GPSPosition")
        pos = answer["result"]["data"]
        here = lla_to_ned(LLA(pos["Latitude"], pos["Longitude"], pos["Altitude"]), HOME)
        if (here - target).norm_m < tol_m:
            return here
        if loop.time() > deadline:
            raise AssertionError(f"vehicle at {here}, wanted {target}")
        await asyncio.sleep(0.1)


async def test_commands_over_mqtt_fly_the_vehicle_where_asked(broker_url):
    async with drone_process(broker_url, "QUAD_CLI", "--home", HOME_ARG, "--speedup", "20"):
        async with Operator(broker_url) as op:
            await op.heartbeat("QUAD_CLI")

            async def ok(**fields):
                answer = await op.command("QUAD_CLI", **fields)
                assert answer["drone_id"] == "QUAD_CLI"
                assert answer["command"] == fields["command"]
                assert answer["ok"], answer
                return answer

            armed = await ok(command="arm")
            assert armed["result"]["arming_time_s"] == pytest.approx(3.0, abs=0.3)
            await ok(command="takeoff", value=10)
            await until_near(op, "QUAD_CLI", NED(0, 0, -10))

            target = ned_to_lla(NED(60, 40, 0), HOME)
            await ok(command="navigate", lat=target.lat, lon=target.lon, altitude_delta=15)
            await until_near(op, "QUAD_CLI", NED(60, 40, -15))
            await ok(command="changeN", value=-20)
            await until_near(op, "QUAD_CLI", NED(40, 40, -15))
            await ok(command="changeE", value=10)
            await until_near(op, "QUAD_CLI", NED(40, 50, -15))
            await ok(command="altitude", value=5)
            await until_near(op, "QUAD_CLI", NED(40, 50, -20))

            picture = await ok(command="takepic")
            shot = picture["result"]["capture"]
            assert lla_to_ned(LLA(shot["lat"], shot["lon"], shot["alt_m"]), HOME).horizontal_m == (
                pytest.approx(NED(40, 50).horizontal_m, abs=1.5)
            )

            refused = await op.command("QUAD_CLI", command="disarm")
            assert not refused["ok"] and "in flight" in refused["error"]

            await ok(command="land")
            await until_landed(op, "QUAD_CLI")
            final = await until_near(op, "QUAD_CLI", NED(40, 50, 0), tol_m=1.0)
            assert final.d == pytest.approx(0, abs=0.2)
            await ok(command="disarm")
            status = await op.command("QUAD_CLI", command="objrequest", value="FlightStatus")
            assert status["result"]["data"]["Armed"] == "Disarmed"


async def until_landed(op: Operator, drone_id: str, timeout_s: float = 60.0) -> None:
    loop = asyncio.get_running_loop()
    deadline = loop.time() + timeout_s
    while (await op.command(drone_id, command="objrequest", value="FlightStatus"))["result"][
        "data"
    ]["InAir"]:
        assert loop.time() < deadline, "vehicle did not land"
        await asyncio.sleep(0.1)


def ten_waypoint_mission(home: LLA) -> list[dict]:
    steps: list[dict] = [
        {"command": "arm"},
        {"command": "takeoff", "value": 10},
        {"command": "wait_for_flight"},
    ]
    for i in range(10):
        wp = ned_to_lla(NED(20 * (i // 2), 25 * (i % 2)), home)
        steps.append({"command": "navigate", "lat": wp.lat, "lon": wp.lon, "altitude_delta": 10})
        steps.append({"command": "wait_for_flight"})
        if i % 3 == 0:
            steps.append({"command": "sleep", "value": 2})
    steps += [{"command": "land"}, {"command": "wait_for_flight"}, {"command": "disarm"}]
    return steps


async def test_ten_waypoint_mission_completes_with_progress_and_log(mosquitto_broker, tmp_path):
    from dronefleet.messaging.missions import encode_steps_base64

    logs = tmp_path / "logs"
    steps = ten_waypoint_mission(HOME)
    async with (
        drone_process(
            mosquitto_broker,
            "QUAD_M",
            "--home",
            HOME_ARG,
            "--speedup",
            "25",
            "--log-dir",
            str(logs),
        ),
        Operator(mosquitto_broker) as op,
    ):
        await op.heartbeat("QUAD_M")
        await op.send_mission(
            "QUAD_M", request_id="r1", mission_id="ten", mission=encode_steps_base64(steps)
        )
        done = await op.wait_for(
            lambda: [p for p in op.progress("ten") if p["event"] in ("completed", "failed")],
            timeout_s=120,
        )
        assert done[0]["event"] == "completed", done
        events = op.progress("ten")
        assert events[0]["event"] == "accepted" and events[0]["step_count"] == len(steps)
        assert events[0]["decode_time_s"] < 0.5
        step_reports = [p for p in events if p["event"] == "step"]
        assert [p["step_index"] for p in step_reports] == list(range(len(steps)))
        assert [p["command"] for p in step_reports] == [s["command"] for s in steps]
        for report in step_reports:
            assert report["position"]["lat"] and report["step_duration_s"] >= 0
        sleeps = [p for p in step_reports if p["command"] == "sleep"]
        assert all(p["step_duration_s"] == pytest.approx(2.0, abs=0.2) for p in sleeps)
        last_wp = ned_to_lla(NED(20 * 4, 25), HOME)
        end = done[0]["position"]
        assert lla_to_ned(LLA(end["lat"], end["lon"], end["alt_m"]), HOME).horizontal_m == (
            pytest.approx(lla_to_ned(last_wp, HOME).horizontal_m, abs=2.0)
        )
        # The Logger has its own broker connection: give it the time to write the last line.
        log_file = logs / "QUAD_M.jsonl"
        for _ in range(100):
            if log_file.exists() and b'"event":"completed"' in log_file.read_bytes():
                break
            await asyncio.sleep(0.05)
    lines = read_jsonl(log_file)
    logged = [ln for ln in lines if ln.get("topic") == "QUAD_M/mission/in"]
    assert len(logged) == 1 and logged[0]["payload"]["mission_id"] == "ten"
    logged_steps = [
        ln["payload"]
        for ln in lines
        if ln.get("topic") == "QUAD_M/mission/out" and ln["payload"].get("event") == "step"
    ]
    assert [p["command"] for p in logged_steps] == [s["command"] for s in steps]
    commands = [ln for ln in lines if ln.get("kind") == "command" or ln.get("event") == "command"]
    assert len(commands) >= len(
        [s for s in steps if s["command"] not in ("wait_for_flight", "sleep")]
    )
