"""The pre-flight checklist (issue 14): each drone of a mission checked before it flies.

QGroundControl shows a checklist before a flight and ArduPilot refuses to arm on its own
pre-arm checks; a fleet operator needs the same for every drone of a mission at once, before
Send. For each drone of the plan:

* **battery**: the share's estimate (the way home included) against what the drone has, from the
  plan itself; a share it cannot finish is refused by the planner, one handed over in flight
  says so;
* **gps**: a 3-D fix with at least :data:`MIN_SATELLITES` satellites (ArduPilot's GPS arming
  check asks for 6);
* **link**: the drone not lost (the Drone Identifier's verdict: heard within three intervals of
  the ground's awake time, so a stall of the ground's own loop is not a silence), the drone's
  link to its autopilot up, and the autopilot's own link-loss failsafe not off (a vehicle
  whose drone software died hovered until its battery was flat: issue 26);
* **sensors**: what the mission's steps use is on board: a camera for ``takepic`` and
  ``camera_trigger``, a measuring sensor for ``read_sensors`` (the drone's gear, Listing 4.2);
* **fence** (only when the mission has one): the drone starts inside it; every share is checked
  against it whole by the planner (ground/planner/geofence.py), and the fence goes with each leg;
* **wind**: the autopilot's own estimate, below :data:`WIND_SHARE` of the vehicle's top speed;
  ``unknown`` when the drone reports none: never guessed.

Each check is ``pass``, ``fail`` or ``unknown``, with the reason. A failure blocks the start
(422, the checklist in the answer) unless the operator overrides it with a reason, which is
audited; ``unknown`` never blocks but is shown. A refusal by the planner itself (battery, fence)
cannot be overridden.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from enum import StrEnum
from typing import Any

from pydantic import BaseModel

from dronefleet.errors import InvalidInput
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.fleet_view import DroneView
from dronefleet.ground.planner.launch import Gate, MissionSpec, Planned, planned
from dronefleet.ground.planner.service import MissionPlanner, PlannerError
from dronefleet.messaging.commands import Command
from dronefleet.messaging.fence import FenceShape, Geofence

#: Satellites a 3-D fix needs to pass (ArduPilot's arming check: 6).
MIN_SATELLITES = 6
#: Wind above this share of the vehicle's top speed fails: upwind it would barely make way.
WIND_SHARE = 0.8
#: The top speed assumed for a drone that reports none (the dissertation quad's 10 m/s).
DEFAULT_SPEED_MPS = 10.0
_CAMERA = {Command.TAKEPIC, Command.CAMERA_TRIGGER}


class CheckName(StrEnum):
    BATTERY = "battery"
    GPS = "gps"
    LINK = "link"
    SENSORS = "sensors"
    FENCE = "fence"
    WIND = "wind"


class CheckStatus(StrEnum):
    PASS = "pass"
    FAIL = "fail"
    UNKNOWN = "unknown"  # the drone does not report it: shown, never blocks


class Check(BaseModel):
    check: CheckName
    status: CheckStatus
    reason: str


class DroneChecks(BaseModel):
    drone_id: str
    ok: bool  # no check failed
    checks: list[Check]


class PreflightReport(BaseModel):
    """The checklist of every drone of a mission."""

    ok: bool  # no check failed on any drone
    overridable: bool  # its failures may be overridden (the planner itself refused none)
    drones: list[DroneChecks]

    def failures(self) -> list[str]:
        return [
            f"{d.drone_id} {c.check.value}: {c.reason}"
            for d in self.drones
            for c in d.checks
            if c.status is CheckStatus.FAIL
        ]


class PreflightFailed(InvalidInput):
    """A mission whose checklist failed, not overridden; its body carries the checklist."""


# -- the checks, each from what the Drone Identifier knows -----------------------------------------
def _check(name: CheckName, status: CheckStatus, reason: str) -> Check:
    return Check(check=name, status=status, reason=reason)


def battery(share: dict[str, Any], reserve_pct: float) -> Check:
    used, end = share["battery_used_pct"], share["battery_end_pct"]
    has = f"needs {used:.0f} % for {share['duration_s']:.0f} s, has {used + end:.0f} %"
    if end >= reserve_pct:
        why = f"{has}: ends at {end:.0f} % (reserve {reserve_pct:g} %)"
        return _check(CheckName.BATTERY, CheckStatus.PASS, why)
    # Accepted below the reserve only with a handover planned (shares.assign notes it).
    why = f"{has}: an idle drone takes over in flight before the {reserve_pct:g} % reserve"
    return _check(CheckName.BATTERY, CheckStatus.PASS, why)


def gps(record: dict[str, Any]) -> Check:
    report = record.get("gps")
    if not isinstance(report, dict):
        return _check(CheckName.GPS, CheckStatus.UNKNOWN, "the drone reports no GPS status")
    fix, satellites = report.get("fix"), int(report.get("satellites") or 0)
    hdop = f", HDOP {report['hdop']:g}" if report.get("hdop") is not None else ""
    if fix != "3d":
        return _check(CheckName.GPS, CheckStatus.FAIL, f"no 3-D fix (fix: {fix})")
    if satellites < MIN_SATELLITES:
        why = f"3-D fix on {satellites} satellites, fewer than {MIN_SATELLITES}"
        return _check(CheckName.GPS, CheckStatus.FAIL, why)
    return _check(CheckName.GPS, CheckStatus.PASS, f"3-D fix, {satellites} satellites{hdop}")


def link(record: dict[str, Any]) -> Check:
    status, ago = record.get("status"), record.get("seen_ago_s")
    interval = float(record.get("heartbeat_interval_s") or 5.0)
    if status == "autopilot link lost":
        why = "heartbeats come, but the drone's software cannot reach its autopilot"
        return _check(CheckName.LINK, CheckStatus.FAIL, why)
    if not isinstance(ago, int | float):
        return _check(CheckName.LINK, CheckStatus.UNKNOWN, "never heard")
    if status != "online":  # the Identifier's verdict, counted in the ground's awake time
        why = f"last heartbeat {ago:.0f} s ago"
        lost_after = record.get("lost_after_s")  # the Identifier's own figure, in every record
        if isinstance(lost_after, int | float):
            why += f" (lost after {lost_after:.1f} s)"
        return _check(CheckName.LINK, CheckStatus.FAIL, why)
    # ``ago`` is wall time: a ground stalled by a busy host reads heartbeats late, and it is the
    # Identifier's awake-time rule, not this clock, that says when a drone is lost (issue 19; the
    # suite's pre-flight once refused a drone heard "2 s ago" at 10x on a loaded host).
    why = f"last heartbeat {ago:.1f} s ago (one every {interval:.1f} s)"
    failsafe = record.get("link_failsafe")
    if isinstance(failsafe, dict) and failsafe.get("action") == "off":
        why += (
            "; but its autopilot's own link-loss failsafe is off: if the drone's software dies"
            " the vehicle hovers until its battery is flat (turn it on, or run the drone with"
            " --set-autopilot-failsafe)"
        )
        return _check(CheckName.LINK, CheckStatus.FAIL, why)
    if isinstance(failsafe, dict) and failsafe.get("action") not in (None, "unknown"):
        after = failsafe.get("timeout_s")
        why += f"; autopilot failsafe: {failsafe['action']}" + (
            f" after {after:g} s without it" if isinstance(after, int | float) else ""
        )
    return _check(CheckName.LINK, CheckStatus.PASS, why)


def sensors(record: dict[str, Any], commands: set[str]) -> Check:
    needs_camera = bool(commands & _CAMERA)
    needs_sensor = Command.READ_SENSORS in commands
    if not (needs_camera or needs_sensor):
        return _check(CheckName.SENSORS, CheckStatus.PASS, "the mission uses no sensor or camera")
    gear = record.get("sensors")
    if not isinstance(gear, dict):
        return _check(CheckName.SENSORS, CheckStatus.UNKNOWN, "the drone's gear is not known yet")
    has_camera = any(str(k).upper() == "CAMERA" for k in gear)
    measuring = sorted(str(k) for k in gear if str(k).upper() != "CAMERA")
    missing = [
        what
        for what, needed, there in (
            ("a camera (takepic)", needs_camera, has_camera),
            ("a sensor (read_sensors)", needs_sensor, bool(measuring)),
        )
        if needed and not there
    ]
    if missing:
        why = f"the mission needs {' and '.join(missing)}; on board: {_listed(gear)}"
        return _check(CheckName.SENSORS, CheckStatus.FAIL, why)
    return _check(CheckName.SENSORS, CheckStatus.PASS, f"on board: {_listed(gear)}")


def fence(record: dict[str, Any], geofence: Geofence) -> Check:
    view = DroneView.from_public(record)
    if view is None:
        return _check(CheckName.FENCE, CheckStatus.UNKNOWN, "the drone's position is not known")
    shape = FenceShape(geofence, view.position)
    for what, here in (("its position", view.position), ("its home", view.home)):
        why = shape.breach(LLA(here.lat, here.lon, view.home.alt_m), view.home)
        if why is not None:
            return _check(CheckName.FENCE, CheckStatus.FAIL, f"{what} is {why}")
    ceiling = f", ceiling {geofence.ceiling_m:g} m" if geofence.ceiling_m is not None else ""
    why = f"starts inside the fence{ceiling}; the fence goes with its leg"
    return _check(CheckName.FENCE, CheckStatus.PASS, why)


def wind(record: dict[str, Any]) -> Check:
    report = record.get("wind")
    if not isinstance(report, dict) or report.get("speed_mps") is None:
        return _check(CheckName.WIND, CheckStatus.UNKNOWN, "the autopilot reports no wind estimate")
    speed, origin = float(report["speed_mps"]), float(report.get("from_deg") or 0.0)
    flight = record.get("flight") if isinstance(record.get("flight"), dict) else {}
    top = float((flight or {}).get("speed_mps") or DEFAULT_SPEED_MPS)
    limit = WIND_SHARE * top
    said = f"{speed:.1f} m/s from {origin:.0f}°"
    if speed > limit:
        why = f"{said}, above {limit:.1f} m/s ({WIND_SHARE:.0%} of its {top:g} m/s)"
        return _check(CheckName.WIND, CheckStatus.FAIL, why)
    return _check(CheckName.WIND, CheckStatus.PASS, f"{said} (limit {limit:.1f} m/s)")


def _listed(gear: dict[str, Any]) -> str:
    return ", ".join(sorted(str(k) for k in gear)) or "nothing"


# -- a mission's checklist -------------------------------------------------------------------------
def drone_checks(
    record: dict[str, Any], battery_check: Check, commands: set[str], fence_check: Check | None
) -> DroneChecks:
    checks = [battery_check, gps(record), link(record), sensors(record, commands)]
    if fence_check is not None:
        checks.append(fence_check)
    checks.append(wind(record))
    ok = all(c.status is not CheckStatus.FAIL for c in checks)
    return DroneChecks(drone_id=str(record.get("drone_id")), ok=ok, checks=checks)


def report_of(
    spec: MissionSpec, done: Planned, records: list[dict[str, Any]], reserve_pct: float
) -> PreflightReport:
    """The checklist of a planned mission (every share's drone)."""
    by_id = {str(r.get("drone_id")): r for r in records}
    geofence = spec.options.geofence
    drones = []
    for drone_id, prefix, indices, end, est in done.shares:
        steps = [*prefix, *(done.work[i] for i in indices), *end]
        commands = {str(s.get("command")) for s in steps}
        record = by_id.get(drone_id, {"drone_id": drone_id})
        fenced = fence(record, geofence) if geofence is not None else None
        drones.append(drone_checks(record, battery(est, reserve_pct), commands, fenced))
    return PreflightReport(ok=all(d.ok for d in drones), overridable=True, drones=drones)


def refused_report(
    refusal: PlannerError, records: list[dict[str, Any]], spec: MissionSpec
) -> PreflightReport:
    """The checklist when the planner itself refused a drone's share (its battery cannot finish
    it, or it leaves the fence): that check fails with the planner's reason, the others are
    still shown, and nothing can be overridden."""
    refused = str(refusal.extra["drone_id"])
    failed = _check(CheckName(refusal.extra["check"]), CheckStatus.FAIL, refusal.detail)
    by_id = {str(r.get("drone_id")): r for r in records}
    commands = _commands_asked(spec)
    geofence = spec.options.geofence
    drones = []
    for drone_id in spec.drones or [refused]:
        record = by_id.get(drone_id, {"drone_id": drone_id})
        unplanned = _check(
            CheckName.BATTERY, CheckStatus.UNKNOWN, f"not planned: {refused} refused"
        )
        fenced = fence(record, geofence) if geofence is not None else None
        if drone_id == refused and failed.check is CheckName.BATTERY:
            drones.append(drone_checks(record, failed, commands, fenced))
        elif drone_id == refused:
            drones.append(drone_checks(record, unplanned, commands, failed))
        else:
            drones.append(drone_checks(record, unplanned, commands, fenced))
    return PreflightReport(ok=False, overridable=False, drones=drones)


def _commands_asked(spec: MissionSpec) -> set[str]:
    if spec.steps is not None:
        return {str(s.get("command")) for s in spec.steps if isinstance(s, dict)}
    action = getattr(spec.area, "action", None)
    return {str(getattr(action, "value", action))} if action else set()


async def preflight(planner: MissionPlanner, spec: MissionSpec) -> PreflightReport:
    """Plan ``spec`` as a start would, and check each of its drones; nothing is sent."""
    records = await planner.fleet.records()
    try:
        done = await planned(planner, spec, records)
    except PlannerError as exc:
        if exc.extra.get("check") in {CheckName.BATTERY, CheckName.FENCE}:
            return refused_report(exc, records, spec)
        raise
    return report_of(spec, done, records, planner.reserve_pct)


def gate(
    planner: MissionPlanner,
    override: str | None,
    on_override: Callable[[list[str]], Awaitable[None]],
) -> Gate:
    """The check a start runs on its plan (``launch.create``/``start``): a failed checklist
    refuses it, unless ``override`` gives the operator's reason (then ``on_override`` records
    what was overridden, and it flies)."""

    async def check(spec: MissionSpec, done: Planned, records: list[dict[str, Any]]) -> None:
        report = report_of(spec, done, records, planner.reserve_pct)
        failures = report.failures()
        if not failures:
            return
        if override:
            await on_override(failures)
            return
        raise PreflightFailed(
            "pre-flight checks failed: " + "; ".join(failures)
            + ". Fix them, or override with a reason to fly anyway",
            preflight=report.model_dump(mode="json"),
        )  # fmt: skip

    return check
