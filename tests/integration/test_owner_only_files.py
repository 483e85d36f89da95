"""Every file the ground or a drone writes is 0600, every folder it makes 0700 (issue 25 item 5).

Telemetry, the audit log, flight logs, mission reports and pictures were 0644 in folders 0755.
Two ways in: ``dronefleet demo`` as a process of its own (the command line sets a private umask:
SQLite's -wal/-shm files, everything a library makes), and the ground services with a drone in
this process, whose umask stays the usual 022 (so the writers' own modes are what is checked),
flying a survey whose pictures the ground fetches, thumbnails and zips. Files an earlier version
left readable are closed to others when reopened.
"""

from __future__ import annotations

import asyncio
import os
import stat
import subprocess
import sys
from pathlib import Path

import httpx
import pytest

from dronefleet.drone.config import DroneConfig
from dronefleet.drone.report_store import ReportStore
from dronefleet.experiments.scenarios import rectangle
from dronefleet.geo.types import LLA
from dronefleet.ground.state import StateStore
from dronefleet.ground.telemetry.sqlite_store import SqliteTelemetryStore
from dronefleet.simfleet import SimFleet
from support.ground_api import flown, local_ground

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)


def modes(root: Path) -> dict[str, int]:
    """Every folder and file under ``root`` (itself included), by its path from ``root``."""
    found = {".": stat.S_IMODE(root.stat().st_mode)}
    for path in root.rglob("*"):
        found[str(path.relative_to(root))] = stat.S_IMODE(path.lstat().st_mode)
    return found


def open_to_others(root: Path) -> dict[str, str]:
    wrong = {}
    for name, mode in modes(root).items():
        want = 0o700 if (root / name).is_dir() else 0o600
        if mode != want:
            wrong[name] = oct(mode)
    return wrong


def test_the_demo_writes_only_files_of_its_owner(tmp_path):
    state = tmp_path / "made-by-the-demo" / "state"
    run = subprocess.run(
        [sys.executable, "-m", "dronefleet.cli", "demo", "--once", "--speedup", "max",
         "--http", "127.0.0.1:0", "--drones", "2", "--state-dir", str(state)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    found = modes(tmp_path / "made-by-the-demo")
    assert {"state/ground.db", "state/telemetry.db", "state/logs/QUAD_1.jsonl"} <= found.keys()
    assert any(name.endswith(".jpg") for name in found), sorted(found)
    assert open_to_others(tmp_path / "made-by-the-demo") == {}


@pytest.fixture
def usual_umask():
    """This process creates files 0644 and folders 0755 unless a writer asks otherwise."""
    old = os.umask(0o022)
    yield
    os.umask(old)


async def test_the_ground_and_a_drone_write_only_files_of_their_owner(
    embedded_broker, tmp_path, usual_umask
):
    root = tmp_path / "private"
    ground = local_ground(embedded_broker, root / "ground", "owner-only-planner")
    async with ground, SimFleet(speedup=20) as fleet:
        drone = root / "drone"
        config = DroneConfig(
            drone_id="CAM",
            log_dir=drone / "logs",
            state_dir=drone / "state",
            gear_dir=drone / "gear",
        )
        await fleet.add_drone(config, embedded_broker, home=HOME)
        headers = {"Authorization": f"Bearer {ground.operator_token}"}
        async with httpx.AsyncClient(base_url=ground.http_url, headers=headers, timeout=30) as api:
            for _ in range(100):
                if (await api.get("/api/v1/drones/CAM")).status_code == 200:
                    break
                await asyncio.sleep(0.1)
            area = {"polygon": rectangle(10, 0, 20, 20), "spacing_m": 10, "altitude_m": 15,
                    "action": "takepic", "hold_s": 0}  # fmt: skip
            spec = {"drones": ["CAM"], "area": area, "options": {"collaboration": False}}
            detail = await flown(api, spec)
            assert detail["state"] == "completed", detail["error"]
            photos = f"/api/v1/missions/{detail['mission_id']}/photos"
            for _ in range(300):
                listed = (await api.get(photos)).json()
                if listed and all(p["stored"] for p in listed):
                    break
                await asyncio.sleep(0.1)
            assert (await api.get(f"{photos}.zip")).status_code == 200
            # While everything is open: the SQLite -wal and -shm files are there too.
            found = modes(root)
            names = sorted(found)
            for wanted in ("ground/g.db-wal", "ground/t.db-shm", "drone/state/reports.db-wal"):
                assert wanted in found, names
            assert any(n.startswith("ground/photos/") and n.endswith(".jpg") for n in names), names
            assert any("/thumbs/" in n for n in names) and any(
                n.endswith("photos.zip") for n in names
            )
            assert any(n.startswith("drone/logs/pictures/") for n in names), names
            assert "drone/logs/CAM.jsonl" in found, names
            assert open_to_others(root) == {}


async def test_a_file_an_earlier_version_left_readable_is_closed_to_others(tmp_path, usual_umask):
    paths = [tmp_path / name for name in ("ground.db", "telemetry.db", "reports.db")]
    for path in paths:
        path.touch(mode=0o644)
        path.chmod(0o644)
    state = await StateStore(paths[0]).open()
    telemetry = SqliteTelemetryStore(str(paths[1]))
    await telemetry.open()
    reports = ReportStore(paths[2])
    try:
        for path in paths:
            assert stat.S_IMODE(path.stat().st_mode) == 0o600, path
    finally:
        await state.close()
        await telemetry.close()
        if reports.db is not None:
            reports.db.close()
