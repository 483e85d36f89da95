"""``python -m dronefleet.sim.uavtalk`` serves several simulated dRonin boards, one port each."""

from __future__ import annotations

import asyncio
import sys

import pytest

from dronefleet.drone.fc.uavtalk import open_flight_controller
from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA

pytestmark = pytest.mark.integration


async def test_the_uavtalk_simulator_runs_as_its_own_process():
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "dronefleet.sim.uavtalk",
        "--uavtalk", "tcp:127.0.0.1:0", "--count", "2", "--speedup", "10",
        "--home", "40.63,-8.659,10", "--spacing-m", "20",
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.PIPE,
    )  # fmt: skip
    fcs = []
    try:
        line = (await asyncio.wait_for(proc.stdout.readline(), 20)).decode()
        assert line.startswith("uavtalk sim ready:"), line
        endpoints = dict(item.split("=", 1) for item in line.split(":", 1)[1].split())
        assert sorted(endpoints) == ["UAVTALK_1", "UAVTALK_2"]
        for url in endpoints.values():
            fcs.append(await open_flight_controller(url))
        homes = [fc.home() for fc in fcs]
        assert lla_to_ned(homes[1], homes[0]).e == pytest.approx(20.0, abs=0.05)
        assert homes[0] == LLA(40.63, -8.659, 10.0)
        await fcs[0].arm()
        assert fcs[0].state().armed and not fcs[1].state().armed
        assert fcs[0].clock.speedup == pytest.approx(10, rel=0.3)
    finally:
        for fc in fcs:
            await fc.close()
        proc.terminate()
        await asyncio.wait_for(proc.wait(), 10)
    assert proc.returncode in (0, -15)
