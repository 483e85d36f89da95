"""Rule 5 (:mod:`.deconflict`): a share near a lost drone flown around it (:func:`around`): its
work's steps within the orphan's keep-out on another layer, the way there dropped, its ways to
and from the work planned around the keep-out (:mod:`.ways`)."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.deconflict.shares import Share
from dronefleet.ground.planner.deconflict.ways import (
    AROUND_FLOOR_M,
    AROUND_M,
    AroundTry,
    way_across,
    way_down,
    way_up,
)
from dronefleet.ground.planner.orphans import Orphan
from dronefleet.messaging.commands import Command

#: Metres beyond its keep-out within which steps move too, tried in turn, so that the way down
#: to the work's height starts once away from it.
AROUND_MARGINS_M = (0.0, 5.0, 10.0, 20.0, 40.0)


def around_tries() -> list[tuple[float, float]]:
    return [(margin, up) for margin in AROUND_MARGINS_M for up in AROUND_M]


def around(
    share: Share,
    orphans: list[Orphan],
    origin: LLA,
    around_m: float,
    margin_m: float,
    ceiling_m: float | None = None,
) -> Share | None:
    """``share`` with its steps near a lost drone flown on another layer: every navigate of its
    work within an orphan's widest keep-out (plus ``margin_m``) and within reach of its height
    is flown ``around_m`` above its highest point (below its lowest, when negative); a way
    there in its prefix that ends inside the keep-out (the replacement's way to a lost drone's
    last point) is dropped. Its way to the work is planned around the keep-out (issue 26:
    before, a drone whose take-off column lay inside one was refused every plan):
    :func:`.way_up` lifts a drone on the ground there off below the orphan and out of the
    keep-out low, a way to the first work point that passes over the keep-out is flown
    above the orphan (:func:`.way_across`), and a drone whose home lies in one comes back the
    way it left (:func:`.way_down`). None when nothing is near, or a moved step would
    leave the altitude limits."""
    attempt = AroundTry(share, tuple(orphans), origin, around_m, margin_m, ceiling_m)
    home_up = attempt.home_up
    changed = False

    def moved(step: dict[str, Any]) -> dict[str, Any] | bool | None:
        """The step on the other layer; False when it is not near; None when it cannot be."""
        if step.get("command") != Command.NAVIGATE or step.get("altitude_delta") is None:
            return False
        height = float(step["altitude_delta"])
        where = LLA(float(step["lat"]), float(step["lon"]), share.home.alt_m + height)
        for orphan in orphans:
            low, high = orphan.heights_m(origin)
            up = home_up + height
            if not orphan.near(where, margin_m):
                continue
            if low - AROUND_M[0] < up < high + AROUND_M[0]:
                target = (high + around_m if around_m > 0 else low + around_m) - home_up
                if target < AROUND_FLOOR_M or (ceiling_m is not None and target > ceiling_m):
                    return None
                return {**step, "altitude_delta": round(target, 2)}
        return False

    work: list[dict[str, Any]] = []
    for step in share.work:
        new = moved(step)
        if new is None:
            return None
        changed |= new is not False
        work.append(step if new is False else new)  # type: ignore[arg-type]
    prefix = _without_ways_in(share.prefix, moved)
    changed |= len(prefix) != len(share.prefix)
    up = way_up(attempt, prefix)
    if up is None:
        return None
    prefix, lifted_at = up
    changed |= lifted_at is not None
    across = way_across(attempt, prefix, work, lifted_at)
    if across is None:
        return None
    changed |= across is not prefix
    end = way_down(attempt, work)
    if end is None:
        return None
    changed |= end is not share.end
    if not changed:
        return None
    return replace(share, prefix=across, work=work, end=end)


def _without_ways_in(steps: list[dict[str, Any]], moved: Any) -> list[dict[str, Any]]:
    """``steps`` without a navigate (and its wait) that ``moved`` finds near a lost drone: its
    way to the lost drone's last point, flown straight to the work instead."""
    kept: list[dict[str, Any]] = []
    skip = False
    for step in steps:
        if skip and step.get("command") == Command.WAIT_FOR_FLIGHT:
            skip = False
            continue
        skip = False
        if moved(step) is not False:
            skip = True
            continue
        kept.append(step)
    return kept
