"""The checks after a chaos run: reports, once, ended, home, apart (see the package's docstring)."""

from __future__ import annotations

import contextlib
import json
import math
import sqlite3
from collections import defaultdict
from collections.abc import Iterator
from typing import Any

from support.chaos.rig import ENDED, Rig, fetch
from support.chaos.schedule import SEPARATION_H_M, SEPARATION_V_M


def judge(rig: Rig, detail: dict[str, Any], start: float) -> tuple[dict[str, str], dict]:
    mission_id = detail["mission_id"]
    with contextlib.suppress(OSError):
        (rig.tmp / "mission.json").write_text(json.dumps(detail, indent=1))
    legs = {leg["leg_id"]: leg for leg in detail["legs"]}
    sent = drone_reports(rig, mission_id)
    details: dict[str, Any] = {
        "handovers": [
            {k: h.get(k) for k in ("from_drone", "to_drone", "reason", "committed")}
            for h in detail["handovers"]
        ],
        "error": detail.get("error"),
        "steps_done": detail.get("steps_done"),
        "steps": detail.get("steps"),
    }
    checks = {
        "reports": check_reports(detail, legs, sent, details),
        "once": check_once(detail, legs, sent, details),
        "ended": check_ended(rig, detail, details),
        "home": check_home(rig, detail, details),
        "apart": check_apart(rig, details),
    }
    sep = fetch(rig, "/api/v1/separation", 5)
    if sep is not None:
        details["ground_separation"] = sep
    details["exits"] = {
        name: part.exits for name, part in {**rig.parts, **rig.brokers}.items() if part.exits
    }
    details["tracebacks"] = {
        part.name: text.count("Traceback")
        for part in rig.parts.values()
        if part.log.exists() and (text := part.log.read_text(errors="replace")).count("Traceback")
    }
    return checks, details


def drone_reports(rig: Rig, mission_id: str) -> dict[str, dict[tuple[str, int], dict]]:
    """Per drone, the reports it sent for ``mission_id``'s legs: (leg id, seq) -> report.

    A drone still running keeps every report in its ``reports.db`` and sends it when asked; a
    drone killed for good sent only what its logger saw reach its broker."""
    out: dict[str, dict[tuple[str, int], dict]] = {}
    for drone_id in rig.drones:
        found: dict[tuple[str, int], dict] = {}
        gone = rig.parts[drone_id].gone
        if not gone:
            db = rig.tmp / drone_id / "state" / "reports.db"
            if db.exists():
                with contextlib.closing(sqlite3.connect(f"file:{db}?mode=ro", uri=True)) as c:
                    for leg_id, seq, body in c.execute(
                        "SELECT mission_id, seq, body FROM reports WHERE mission_id LIKE ?",
                        (f"{mission_id}.%",),
                    ):
                        found[(leg_id, seq)] = json.loads(body)
        for line in log_lines(rig, drone_id):
            payload = line.get("payload")
            if not line.get("topic", "").endswith("/mission/out") or not isinstance(payload, dict):
                continue
            leg_id, seq = payload.get("mission_id", ""), payload.get("seq")
            if leg_id.startswith(f"{mission_id}.") and seq is not None:
                found.setdefault((leg_id, seq), payload)
        out[drone_id] = found
    return out


def log_lines(rig: Rig, drone_id: str) -> Iterator[dict[str, Any]]:
    folder = rig.tmp / drone_id / "logs"
    files = sorted(folder.glob(f"{drone_id}.jsonl*"), key=lambda p: p.name, reverse=True)
    for path in files:  # .jsonl.5 ... .jsonl.1, .jsonl: oldest first
        for raw in path.read_bytes().splitlines():
            with contextlib.suppress(ValueError):
                yield json.loads(raw)


def check_reports(detail: dict, legs: dict, sent: dict, details: dict) -> str:
    missing, late = [], []
    ended = detail.get("ended_at")
    for drone_id, reports in sent.items():
        for (leg_id, seq), body in sorted(reports.items()):
            leg = legs.get(leg_id)
            if leg is not None and seq in leg["seqs"]:
                continue
            what = f"{drone_id} {leg_id}#{seq} {body.get('event')}"
            if body.get("step_index") is not None:
                what += f" step {body['step_index']}"
            if leg is None:
                missing.append(what + " (a leg the record does not have)")
            elif leg["role"] == "recovery" and ended and body.get("timestamp", 0) >= ended - 1:
                late.append(what)
            else:
                missing.append(what)
    details["reports_sent"] = sum(len(r) for r in sent.values())
    details["reports_missing"] = missing
    details["reports_late_recovery"] = late
    if missing:
        return f"FAIL: {len(missing)} of {details['reports_sent']} missing"
    return "ok" + (f" ({len(late)} late)" if late else "")


def flown_steps(detail: dict, legs: dict, sent: dict) -> dict[int, list[str]]:
    """Global work index -> the legs (``drone/leg``) that reported its step done, by the
    drones' own reports and the planner's record together."""
    flown: dict[int, set[str]] = defaultdict(set)
    for reports in sent.values():
        for (leg_id, _seq), body in reports.items():
            leg = legs.get(leg_id)
            if leg is None or body.get("event") != "step" or body.get("step_index") is None:
                continue
            k = body["step_index"] - len(leg["prefix"])
            if 0 <= k < len(leg["indices"]):
                flown[leg["indices"][k]].add(f"{leg['drone_id']}/{leg_id}")
    for leg in legs.values():
        for report in leg["reports"]:
            if report.get("index") is not None:
                flown[report["index"]].add(f"{leg['drone_id']}/{leg['leg_id']}")
    return {i: sorted(v) for i, v in flown.items()}


def check_once(detail: dict, legs: dict, sent: dict, details: dict) -> str:
    work = detail["work"]
    required = set(detail["required"] if detail.get("required") is not None else range(len(work)))
    waypoints = [
        i for i, s in enumerate(work) if s.get("command") == "wait_for_flight" and i in required
    ]
    flown = flown_steps(detail, legs, sent)
    twice = {i: flown[i] for i in waypoints if len(flown.get(i, [])) > 1}
    never = [i for i in waypoints if not flown.get(i)]
    by_two = {
        i: who
        for i, who in flown.items()
        if len({w.split("/")[0] for w in who}) > 1 and i not in twice
    }
    details["waypoints"] = len(waypoints)
    details["waypoints_twice"] = twice
    details["waypoints_never"] = never
    details["steps_by_two_drones"] = by_two  # a half-flown navigate may be flown again
    problems = []
    if twice:
        problems.append(f"{len(twice)} reached twice")
    if never and detail["state"] == "completed":
        problems.append(f"{len(never)} never reached")
    return "FAIL: " + ", ".join(problems) if problems else "ok"


def check_ended(rig: Rig, detail: dict, details: dict) -> str:
    could = any(not rig.parts[d].gone for d in rig.drones)
    state = detail["state"]
    if state == "completed" and detail.get("ended_at"):
        return "ok"
    if state in ENDED and not detail.get("ended_at"):
        return f"FAIL: {state} without ended_at"
    if not could:
        return "n/a"
    return f"FAIL: {state}: {(detail.get('error') or '')[:120]}"


def check_home(rig: Rig, detail: dict, details: dict) -> str:
    """Each recovery leg (a drone sent home) needs a cause."""
    by_leg = {h.get("recovery_leg"): h for h in detail["handovers"] if h.get("recovery_leg")}
    called_off = {h.get("to_drone") for h in detail.get("takeovers_cancelled", [])}
    critical = {a.get("drone_id") for a in detail["alarms"] if a.get("level") == "CRITICAL"}
    homes, bad = [], []
    for leg in detail["legs"]:
        if leg["role"] != "recovery":
            continue
        drone_id = leg["drone_id"]
        handover = by_leg.get(leg["leg_id"]) or next(
            (h for h in detail["handovers"] if h["from_drone"] == drone_id), None
        )
        sent_at = leg.get("sent_at") or 0.0
        if handover is not None:
            own = [(a, b) for a, b in rig.touched.get(drone_id, []) if a <= sent_at]
            cause = "alarm" if drone_id in critical else ("own fault" if own else None)
            what = f"{drone_id} ({handover['reason'][:80]})"
        elif drone_id in called_off:
            cause, what = "takeover called off", f"{drone_id} (replacement called off)"
        else:
            cause, what = None, f"{drone_id} (no handover)"
        homes.append(f"{what}: {cause or 'NO CAUSE'}")
        if cause is None:
            bad.append(what)
    details["sent_home"] = homes
    return f"FAIL: {'; '.join(bad)}"[:300] if bad else "ok"


def positions(rig: Rig, drone_id: str) -> list[tuple[float, float, float, float, bool]]:
    """(wall time, lat, lon, alt, in the air) of each telemetry message in the drone's log."""
    out = []
    in_air = False
    for line in log_lines(rig, drone_id):
        payload = line.get("payload")
        if not line.get("topic", "").endswith("/telemetry/out") or not isinstance(payload, dict):
            continue
        f = payload.get("fields") or {}
        if "lat" not in f or "lon" not in f:
            continue
        if "in_air" in f:
            in_air = bool(f["in_air"])
        elif "relative_alt_m" in f:
            in_air = f["relative_alt_m"] > 0.5
        out.append((payload.get("timestamp", line["t"]), f["lat"], f["lon"], f["alt_m"], in_air))
    out.sort()
    return out


def flat_m(lat_a: float, lon_a: float, lat_b: float, lon_b: float) -> float:
    """Horizontal metres between two near points (the local tangent plane: a millimetre's error
    at a hundred metres)."""
    north = math.radians(lat_b - lat_a) * 6_367_449.0
    east = math.radians(lon_b - lon_a) * 6_378_137.0 * math.cos(math.radians(lat_a))
    return math.hypot(north, east)


def check_apart(rig: Rig, details: dict, max_gap_s: float = 1.0) -> str:
    """Closest approach of every pair, sampled every 0.1 s where both have a position from
    within ``max_gap_s`` (a drone whose process was stopped holds its last one: its simulated
    vehicle stood still)."""

    def known(drone_id: str, sample_t: float, t: float) -> bool:
        if t - sample_t <= max_gap_s:
            return True
        return any(a - max_gap_s <= sample_t and t <= b for a, b in rig.frozen.get(drone_id, []))

    tracks = {d: positions(rig, d) for d in rig.drones}
    closest: tuple[float, str, float] | None = None
    breaches = []
    names = rig.drones
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            ta, tb = tracks[a], tracks[b]
            if not ta or not tb:
                continue
            t, end = max(ta[0][0], tb[0][0]), min(ta[-1][0], tb[-1][0])
            ia = ib = 0
            while t <= end:
                while ia + 1 < len(ta) and ta[ia + 1][0] <= t:
                    ia += 1
                while ib + 1 < len(tb) and tb[ib + 1][0] <= t:
                    ib += 1
                pa, pb = ta[ia], tb[ib]
                if known(a, pa[0], t) and known(b, pb[0], t) and pa[4] and pb[4]:
                    h = flat_m(pa[1], pa[2], pb[1], pb[2])
                    v = abs(pa[3] - pb[3])
                    d3 = math.hypot(h, v)
                    if closest is None or d3 < closest[0]:
                        closest = (d3, f"{a}-{b}", t)
                    if h < SEPARATION_H_M and v < SEPARATION_V_M:
                        breaches.append((t, a, b, round(h, 2), round(v, 2)))
                t += 0.1
    if closest is not None:
        details["closest_m"] = round(closest[0], 2)
        details["closest_pair"] = closest[1]
        details["closest_at_s"] = round(closest[2] - rig.t0, 1)
    details["breaches"] = [(round(t - rig.t0, 1), a, b, h, v) for t, a, b, h, v in breaches[:20]]
    if breaches:
        first = breaches[0]
        return f"FAIL: {first[1]}-{first[2]} {first[3]} m apart ({first[4]} m vertically)"
    return "ok" if closest is not None else "n/a"
