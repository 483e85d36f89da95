"""A chaos run: a schedule flown on a rig, then checked."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx

from support.chaos.checks import check_reports, drone_reports, judge
from support.chaos.rig import ENDED, Rig, area_spec, fetch
from support.chaos.schedule import Schedule, mission_wall_s


@dataclass
class Outcome:
    schedule: Schedule
    drones: list[str]
    checks: dict[str, str]  # check -> "ok" | "n/a" | "FAIL: ..."
    state: str
    wall_s: float
    mission_id: str | None = None
    details: dict[str, Any] = field(default_factory=dict)
    events: list[str] = field(default_factory=list)
    folder: str = ""

    @property
    def failed(self) -> list[str]:
        return [name for name, result in self.checks.items() if result.startswith("FAIL")]

    def as_json(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        data["schedule"]["faults"] = [dataclasses.asdict(f) for f in self.schedule.faults]
        return data


CHECKS = ("reports", "once", "ended", "home", "apart")


#: Wall seconds the checks wait at most for reports still on their way (a bridge made again).
REPORTS_WAIT_S = 60.0


def run(schedule: Schedule, tmp: Path, *, settle_s: float = 6.0) -> Outcome:
    """Fly the area through ``schedule``'s faults in a fresh topology under ``tmp``; the checks."""
    tmp.mkdir(parents=True, exist_ok=True)
    began = time.monotonic()
    rig = Rig(tmp, schedule)
    outcome = Outcome(schedule, rig.drones, {}, "not started", 0.0, folder=str(tmp))
    try:
        rig.start()
        # Planning runs in a niced worker process: on a loaded machine it takes its time.
        created = rig.api.post(
            "/api/v1/missions",
            params={"start": "true"},
            json=area_spec(rig.drones),
            timeout=240,
        )
        if created.status_code != 201:
            outcome.state = f"refused {created.status_code}"
            outcome.checks = {c: f"FAIL: mission refused: {created.text[:200]}" for c in CHECKS}
            return outcome
        mission_id = created.json()["mission_id"]
        outcome.mission_id = mission_id
        start = time.time()
        rig.note(f"mission {mission_id} started")
        rig.apply(start)
        last_end = max((f.at_s + f.duration_s for f in schedule.faults), default=0.0)
        deadline = start + last_end + max(60.0, 3 * mission_wall_s(schedule.speedup))
        detail = wait_ended(rig, mission_id, deadline)
        rig.note(f"mission {detail.get('state')}")
        while not rig.faults_done() and time.time() < start + last_end + 30:
            time.sleep(0.2)
        time.sleep(settle_s)
        detail = fetch(rig, f"/api/v1/missions/{mission_id}", 30) or detail
        # Every report must end up in the record: a drone whose broker was stopped comes back
        # once its bridge is made again (Mosquitto tries again after some seconds), and its
        # queued reports follow. Judged when they are all in, or after REPORTS_WAIT_S.
        until = time.time() + REPORTS_WAIT_S
        while detail.get("legs") and time.time() < until:
            legs = {leg["leg_id"]: leg for leg in detail["legs"]}
            if check_reports(detail, legs, drone_reports(rig, mission_id), {}) == "ok":
                break
            time.sleep(2.0)
            detail = fetch(rig, f"/api/v1/missions/{mission_id}", 30) or detail
        outcome.state = detail.get("state", "unknown")
        outcome.checks, outcome.details = judge(rig, detail, start)
    except Exception as exc:
        outcome.state = f"error: {exc!r}"[:300]
        outcome.checks = {c: f"FAIL: run error {exc!r}"[:300] for c in CHECKS}
    finally:
        with contextlib.suppress(Exception):
            rig.close()
        outcome.events = [f"{t - rig.t0:7.1f}s {what}" for t, what in rig.events]
        outcome.wall_s = time.monotonic() - began
        with contextlib.suppress(Exception):
            (tmp / "outcome.json").write_text(json.dumps(outcome.as_json(), indent=1, default=str))
    return outcome


def wait_ended(rig: Rig, mission_id: str, deadline: float) -> dict[str, Any]:
    detail: dict[str, Any] = {}
    while time.time() < deadline:
        with contextlib.suppress(httpx.HTTPError, ValueError):
            answer = rig.api.get(f"/api/v1/missions/{mission_id}", timeout=5)
            if answer.status_code == 200:
                detail = answer.json()
                if detail["state"] in ENDED:
                    return detail
        time.sleep(0.5)
    return detail
