"""The ways to and from the work of a share going around lost drones (rule 5, :mod:`.around`):
up out of a keep-out it takes off in (:func:`way_up`), across one on its way to the work
(:func:`way_across`), down into one its home lies in (:func:`way_down`); and what one try of
going around is planned with (:class:`AroundTry`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from dronefleet.geo.ned import lla_to_ned, ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.deconflict.shares import Share
from dronefleet.ground.planner.orphans import Orphan
from dronefleet.messaging.commands import Command

#: Around a lost drone (issue 26): the heights tried for a share's steps near it, metres above
#: (below) the orphan's highest (lowest) point: clear of the 3 m vertical minimum with 2 m for
#: the autopilot's altitude error and the orphan's own wander.
AROUND_M = (5.0, 8.0, -5.0)
#: Lowest height above home a step is moved down to.
AROUND_FLOOR_M = 3.0
#: Metres an exit point is looked for from a take-off inside a keep-out, and the step between.
EXIT_REACH_M = 150.0
EXIT_STEP_M = 2.0
#: Metres past the keep-out (and its margin) an exit point lies.
EXIT_CLEAR_M = 2.0


@dataclass(frozen=True)
class AroundTry:
    """One try of going around lost drones: the share, the orphans, the plan's origin, the
    height tried (``around_m`` above the orphans' highest point, below their lowest when
    negative), the margin beyond their keep-outs, and the ceiling (None: none)."""

    share: Share
    orphans: tuple[Orphan, ...]
    origin: LLA
    around_m: float
    margin_m: float
    ceiling_m: float | None

    @property
    def home_up(self) -> float:
        """The share's home, metres above the origin."""
        return -lla_to_ned(self.share.home, self.origin).d

    def over_m(self, least_m: float) -> float:
        """The height above home a way over the orphans is flown at, ``least_m`` at least."""
        top = max(o.heights_m(self.origin)[1] for o in self.orphans)
        over = top + max(self.around_m, AROUND_M[0]) - self.home_up
        return max(over, least_m)


def _nav(where: LLA, height_m: float) -> list[dict[str, Any]]:
    return [
        {
            "command": Command.NAVIGATE.value,
            "lat": where.lat,
            "lon": where.lon,
            "altitude_delta": round(height_m, 2),
        },
        {"command": Command.WAIT_FOR_FLIGHT.value},
    ]


def _exit_point(start: LLA, orphans: tuple[Orphan, ...], margin_m: float) -> LLA | None:
    """The nearest point clear of every orphan's widest keep-out (plus ``margin_m`` and
    :data:`EXIT_CLEAR_M`), looked for in 16 directions from ``start``."""
    best: tuple[float, LLA] | None = None
    for k in range(16):
        angle = 2 * math.pi * k / 16
        d = EXIT_STEP_M
        while d <= EXIT_REACH_M and (best is None or d < best[0]):
            where = ned_to_lla(NED(d * math.cos(angle), d * math.sin(angle), 0.0), start)
            if not any(o.near(where, margin_m + EXIT_CLEAR_M) for o in orphans):
                best = (d, where)
                break
            d += EXIT_STEP_M
    return None if best is None else best[1]


def way_up(
    attempt: AroundTry, prefix: list[dict[str, Any]]
) -> tuple[list[dict[str, Any]], LLA | None] | None:
    """A drone on the ground inside an orphan's keep-out whose climb would pass its height:
    its take-off below the orphan (:data:`AROUND_M` under its lowest point, at least
    :data:`AROUND_FLOOR_M` above home) and out of the keep-out at that height; the prefix and
    where it left the keep-out (None: unchanged). None when it cannot be (the orphan too low
    to pass under, no way out)."""
    share, origin, margin_m = attempt.share, attempt.origin, attempt.margin_m
    at = next((i for i, s in enumerate(prefix) if s.get("command") == Command.TAKEOFF), None)
    if share.airborne or at is None or prefix[at].get("value") is None:
        return prefix, None
    start_up = -lla_to_ned(share.start, origin).d
    top_up = start_up + float(prefix[at]["value"])
    inside = []
    for orphan in attempt.orphans:
        low, high = orphan.heights_m(origin)
        if (
            orphan.near(share.start, margin_m)
            and top_up > low - AROUND_M[0]
            and (start_up < high + AROUND_M[0])
        ):
            inside.append(low)
    if not inside:
        return prefix, None
    low_m = min(inside) - AROUND_M[0] - start_up  # metres above where it lifts off
    if low_m < AROUND_FLOOR_M:
        return None  # no room beneath it: this drone cannot leave there
    out = _exit_point(share.start, attempt.orphans, margin_m)
    if out is None:
        return None
    height_m = low_m + start_up - attempt.home_up  # navigate heights are above home
    climbed = [
        *prefix[:at],
        {**prefix[at], "value": round(low_m, 2)},
        *_nav(out, height_m),
        *prefix[at + 1 :],
    ]
    return climbed, out


def way_down(attempt: AroundTry, work: list[dict[str, Any]]) -> list[dict[str, Any]] | None:
    """A drone whose home lies inside an orphan's keep-out, the orphan above it: its way home
    as its way up backwards (its end unchanged otherwise): above the orphan to a point out of
    the keep-out, down there to below the orphan, home at that height and land (an RTL would
    climb to its return height over home, into the orphan). None when it cannot be."""
    share, origin, margin_m = attempt.share, attempt.origin, attempt.margin_m
    home_up = attempt.home_up
    lows = [
        o.heights_m(origin)[0]
        for o in attempt.orphans
        if o.near(share.home, margin_m) and o.heights_m(origin)[1] + AROUND_M[0] > home_up
    ]
    navs = [s for s in work if s.get("command") == Command.NAVIGATE]
    if not lows or not navs or not share.end:
        return share.end
    low_m = min(lows) - AROUND_M[0] - home_up
    if low_m < AROUND_FLOOR_M:
        return None
    out = _exit_point(share.home, attempt.orphans, margin_m)
    if out is None:
        return None
    over = attempt.over_m(float(navs[-1].get("altitude_delta") or 0.0))
    if attempt.ceiling_m is not None and over > attempt.ceiling_m:
        return None
    last = LLA(float(navs[-1]["lat"]), float(navs[-1]["lon"]))
    return [
        *_nav(last, over),
        *_nav(out, over),
        *_nav(out, low_m),
        *_nav(share.home, low_m),
        {"command": Command.LAND.value},
        {"command": Command.WAIT_FOR_FLIGHT.value},
    ]


def way_across(
    attempt: AroundTry,
    prefix: list[dict[str, Any]],
    work: list[dict[str, Any]],
    lifted_at: LLA | None,
) -> list[dict[str, Any]] | None:
    """``prefix`` with its way from where the drone is (``lifted_at``: where it left a keep-out
    low) to the first work point flown above the orphans when that straight way passes within a
    keep-out: climb where it is, cross, and come down onto the work (``prefix`` itself when
    the way is clear). None when the crossing height is over the ceiling."""
    first = next((s for s in work if s.get("command") == Command.NAVIGATE), None)
    if first is None or (not prefix and not attempt.share.airborne):
        return prefix
    navs = [s for s in prefix if s.get("command") == Command.NAVIGATE]
    if navs:
        last = navs[-1]
        here = LLA(float(last["lat"]), float(last["lon"]))
    else:
        here = lifted_at or attempt.share.start
    target = LLA(float(first["lat"]), float(first["lon"]))
    span = lla_to_ned(target, here)
    length = (span.n**2 + span.e**2) ** 0.5
    count = max(1, int(length / EXIT_STEP_M))
    passes = any(
        o.near(
            LLA(
                here.lat + (target.lat - here.lat) * k / count,
                here.lon + (target.lon - here.lon) * k / count,
            ),
            attempt.margin_m,
        )
        for k in range(count + 1)
        for o in attempt.orphans
    )
    if not passes:
        return prefix
    over = attempt.over_m(float(first.get("altitude_delta") or 0.0))
    if attempt.ceiling_m is not None and over > attempt.ceiling_m:
        return None
    return [*prefix, *_nav(here, over), *_nav(target, over)]
