"""An independent ground station flies ``dronefleet sim``: MAVProxy 1.8.75 (issue 10, must-show 1).

MAVProxy is typed into as an operator would at its console. What it hit before: "fence breach" at
every connect, parameters only after an 11 s MAVFTP timeout, ``arm throttle`` then ``takeoff 10``
refused as not armed, ``wp changealt`` reported done with nothing changed. Timeouts are wall
seconds at 5x.
"""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from support.mavproxy import MAVProxy, mavproxy
from support.processes import dronefleet_sim

pytestmark = pytest.mark.integration

HOME = (40.63, -8.659, 10.0)
SPEEDUP = 5.0


async def online(console: MAVProxy) -> int:
    """Waits for the vehicle and its parameter list; the number of parameters received."""
    await console.expect(r"online system 1")
    return int((await console.expect(r"Received (\d+) parameters")).group(1))


async def test_connect_reads_every_parameter_without_false_alarms(tmp_path: Path):
    async with dronefleet_sim(1, HOME, SPEEDUP) as port:
        async with mavproxy(f"udpout:127.0.0.1:{port}", tmp_path) as console:
            count = await online(console)
            assert count >= 300  # ArduPilot Copter's table, with its names and defaults
            await console.send("param show DISARM_DELAY")
            assert float((await console.expect(r"DISARM_DELAY\s+(\S+)")).group(1)) == 10
            await console.send("param set WPNAV_SPEED 800")
            for _ in range(20):  # the set is answered by the vehicle's PARAM_VALUE, a little later
                await console.send("param show WPNAV_SPEED")
                if float((await console.expect(r"WPNAV_SPEED\s+(\S+)")).group(1)) == 800:
                    break
                await asyncio.sleep(0.25)
            else:
                pytest.fail("WPNAV_SPEED never read back as 800")
            await console.send("param show FLTMODE1")
            await console.expect(r"FLTMODE1\s+\S+")
    printed = console.printed()
    assert "fence present" in printed
    assert "fence breach" not in printed.lower(), printed


async def test_arm_throttle_then_takeoff_at_once_and_rtl_disarms_by_itself(tmp_path: Path):
    async with dronefleet_sim(1, HOME, SPEEDUP) as port:
        async with mavproxy(f"udpout:127.0.0.1:{port}", tmp_path) as console:
            await online(console)
            await console.send("mode guided")
            await console.expect(r"Mode GUIDED")
            await console.send("arm throttle")
            await console.send("takeoff 10")  # typed straight after: ArduPilot has armed by its ACK
            await console.expect(r"COMPONENT_ARM_DISARM: ACCEPTED")
            await console.expect(r"NAV_TAKEOFF: ACCEPTED")
            await console.send("mode rtl")
            await console.expect(r"Mode RTL")
            await console.expect(r"DISARMED", 90)
    assert "not armed" not in console.printed().lower()


MISSION = """QGC WPL 110
0\t1\t0\t16\t0\t0\t0\t0\t40.630000\t-8.659000\t10.000000\t1
1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t10.000000\t1
2\t0\t3\t16\t0\t0\t0\t0\t40.630180\t-8.659000\t10.000000\t1
3\t0\t3\t16\t0\t0\t0\t0\t40.630360\t-8.659000\t10.000000\t1
4\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1
"""


async def test_a_mission_is_loaded_edited_read_back_and_flown(tmp_path: Path):
    (tmp_path / "survey.txt").write_text(MISSION)
    async with dronefleet_sim(1, HOME, SPEEDUP) as port:
        async with mavproxy(f"udpout:127.0.0.1:{port}", tmp_path) as console:
            await online(console)
            await console.send(f"wp load {tmp_path / 'survey.txt'}")
            await console.expect(r"TYPE_MISSION: ACCEPTED")
            await console.send("wp changealt 3 25")  # a partial write of item 3
            await console.expect(r"Changed alt for WPs 3:3 to 25")
            await console.expect(r"TYPE_MISSION: ACCEPTED")
            await console.send("wp list")
            await console.expect(r"Requesting 5 waypoints")
            listed = [(await console.expect(r"^(\d+) \d+ \S+ \S+ (\S+) p1=")) for _ in range(5)]
            assert [int(m.group(1)) for m in listed] == [16, 22, 16, 16, 20]
            assert float(listed[3].group(2)) == 25.0  # changed on board, read back
            assert float(listed[2].group(2)) == 10.0  # its neighbour untouched
            await console.send("mode guided")
            await console.expect(r"Mode GUIDED")
            await console.send("arm throttle")
            await console.send("takeoff 10")
            await console.expect(r"NAV_TAKEOFF: ACCEPTED")
            await console.send("mode auto")  # in the air: the mission starts at once
            for seq in (2, 3, 4):
                await console.expect(rf"waypoint {seq}\b", 60)
            await console.expect(r"Mission complete", 90)
            await console.expect(r"DISARMED", 60)
    assert "Mode AUTO" in console.printed()
