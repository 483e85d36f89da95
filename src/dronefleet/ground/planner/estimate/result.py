"""What an estimate says (:class:`Estimate`): the seconds and battery of a list of steps, of a
part of them (:func:`part`, e.g. the way home), and whether the battery finishes them above the
reserve (:func:`can_finish`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple


@dataclass(frozen=True)
class Estimate:
    """Predicted flight time and battery use of a list of steps."""

    duration_s: float
    energy_mah: float
    battery_used_pct: float
    battery_end_pct: float
    per_step: list[float]
    per_step_mah: list[float] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


class Verdict(NamedTuple):
    ok: bool
    reason: str


def part(est: Estimate, start: int, end: int | None = None) -> tuple[float, float]:
    """Seconds and battery % of steps ``start``..``end`` of an estimate (e.g. the way home)."""
    seconds = sum(est.per_step[start:end])
    if est.energy_mah <= 0:
        return seconds, 0.0
    return seconds, est.battery_used_pct * sum(est.per_step_mah[start:end]) / est.energy_mah


def can_finish(est: Estimate, reserve_pct: float = 20.0, home_from: int | None = None) -> Verdict:
    """Whether the battery ends above ``reserve_pct``; the reason either way. ``home_from``: the
    index of the first step of the way home, which the reason then names apart."""
    start = est.battery_end_pct + est.battery_used_pct
    if est.battery_end_pct >= reserve_pct:
        return Verdict(True, f"ends at {est.battery_end_pct:.1f}% (reserve {reserve_pct:g}%)")
    home = ""
    if home_from is not None and home_from < len(est.per_step):
        seconds, used = part(est, home_from)
        home = f" ({used:.1f}% of it for the {seconds:.0f} s way home)"
    return Verdict(
        False,
        f"needs {est.battery_used_pct:.1f}% of the battery for {est.duration_s:.0f} s of flight"
        f"{home} and has {start:.1f}%: it would end at {est.battery_end_pct:.1f}%, below the"
        f" {reserve_pct:g}% reserve",
    )
