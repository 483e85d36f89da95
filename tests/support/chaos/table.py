"""The chaos table and the list of failed checks."""

from __future__ import annotations

from support.chaos.run import CHECKS, Outcome


def table(outcomes: list[Outcome]) -> str:
    head = ["seed", "x", "busy", "faults", *CHECKS, "mission", "wall s"]
    rows = [head]
    for o in outcomes:
        s = o.schedule
        cells = [
            str(s.seed),
            f"{s.speedup:g}",
            str(s.busy),
            " ".join(f.label(o.drones) for f in s.faults) or "none",
            *(short(o.checks.get(c, "-")) for c in CHECKS),
            o.state[:24],
            f"{o.wall_s:.0f}",
        ]
        rows.append(cells)
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def short(result: str) -> str:
    if result.startswith("FAIL"):
        return "FAIL"
    return result.split(" ")[0]


def failures(outcomes: list[Outcome]) -> str:
    """Each failed check with what failed, and the run's events, for the report."""
    out = []
    for o in outcomes:
        if not o.failed:
            continue
        out.append(f"seed {o.schedule.seed} ({o.folder}): mission {o.mission_id} {o.state}")
        for name in o.failed:
            out.append(f"  {name}: {o.checks[name]}")
        for key in ("reports_missing", "waypoints_twice", "breaches", "sent_home", "error"):
            if o.details.get(key):
                out.append(f"  {key}: {str(o.details[key])[:600]}")
        out.extend(f"  | {e}" for e in o.events)
    return "\n".join(out)
