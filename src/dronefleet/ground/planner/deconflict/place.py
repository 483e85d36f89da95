"""Each share placed in turn, rules 1-5 cheapest first (:func:`separate`), or the plan refused
with the first conflict of the share as planned; the notes saying what was changed and why."""

from __future__ import annotations

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.deconflict.around import around, around_tries
from dronefleet.ground.planner.deconflict.candidates import (
    Candidates,
    first_hit,
    flyable,
    traffic_paths,
)
from dronefleet.ground.planner.deconflict.layers import (
    DELAY_STEP_S,
    HOLD_STEP_S,
    LAYERS_M,
    MAX_DELAY_S,
    MAX_HOLD_S,
    delayed,
)
from dronefleet.ground.planner.deconflict.shares import Placed, Share
from dronefleet.ground.planner.deconflict.ways import AROUND_M
from dronefleet.ground.planner.ends import is_layered_return
from dronefleet.ground.planner.orphans import Orphan
from dronefleet.ground.planner.separation import Conflict, SeparationConflict
from dronefleet.ground.planner.trajectory import Trajectory


def separate(
    shares: list[Share],
    traffic: list[Share],
    *,
    origin: LLA | None = None,
    ceiling_m: float | None = None,
    alter_work: bool = False,
) -> list[Placed]:
    """Each share placed so that no two drones come too close (the module's rule), in order.
    Layers that would climb above ``ceiling_m`` (the altitude limit, the fence's ceiling) are
    not tried. With ``alter_work`` (a caller that sends :attr:`Placed.work`), steps near a lost
    drone may be flown on another layer (:func:`around`).

    Raises :class:`SeparationConflict` naming both drones, the time and the place when a share
    cannot be separated. CPU work: callers run it in the planning worker."""
    if not shares:
        return []
    origin = origin or shares[0].home
    fixed = traffic_paths(traffic, origin)
    orphans = [t.orphan for t in traffic if t.orphan is not None]
    placed: list[Placed] = []
    for share in shares:
        options = Candidates(share, origin, ceiling_m)
        first = flyable(options.path(0.0))[0]
        as_planned = first_hit(first, fixed, origin)
        chosen = None if as_planned else (first, 0.0, 0.0, 0.0)
        if chosen is None:
            # A lost drone's keep-out stays (and grows) for ever: held, a start or landing
            # meets it later just the same; only a layer, or going around it, can help.
            static = as_planned is not None and as_planned.lost is not None
            chosen = _place(options, fixed, origin, delays=not static, holds=not static)
        around_m, margin_m = 0.0, 0.0
        if chosen is None and alter_work and orphans:
            for margin_m, around_m in around_tries():
                changed = around(share, orphans, origin, around_m, margin_m, ceiling_m)
                if changed is None:
                    continue
                options = Candidates(changed, origin, ceiling_m)
                chosen = _place(options, fixed, origin, delays=False)
                if chosen is not None:
                    break
        if chosen is None:
            assert as_planned is not None
            tried = (
                f"neither a transit layer up to +{max(LAYERS_M):g} m nor a start delay up to"
                f" {MAX_DELAY_S:g} s keeps them apart"
            )
            if alter_work and orphans:
                tried += f", nor its steps near a lost drone flown {AROUND_M[0]:g} m above or below"
            raise SeparationConflict(as_planned, tried)
        path, delay_s, layer_m, hold_s = chosen
        _, prefix, end = flyable(options.path(layer_m, hold_s))
        work = options.share.work
        notes = _notes(
            share, options.share, as_planned, orphans, around_m, delay_s, layer_m, hold_s
        )
        fixed.append(path)
        placed.append(
            Placed(
                share.drone_id, delayed(prefix, delay_s), end, delay_s, layer_m, notes, hold_s,
                work=None if work is share.work else work,
            )
        )  # fmt: skip
    return placed


def _notes(
    share: Share,
    flown: Share,
    as_planned: Conflict | None,
    orphans: list[Orphan],
    around_m: float,
    delay_s: float,
    layer_m: float,
    hold_s: float,
) -> list[str]:
    """What was changed to keep ``share`` apart (``flown``: as it will be flown), and why."""
    if as_planned is None:
        return []
    work = flown.work
    what = []
    if work is not share.work:
        moved = sum(a != b for a, b in zip(work, share.work, strict=True))
        what.append(
            f"flies {moved} step(s) near lost drone(s)"
            f" {', '.join(sorted({o.drone_id for o in orphans}))} {abs(around_m):g} m"
            f" {'above' if around_m > 0 else 'below'} them"
        )
        if flown.prefix != share.prefix or flown.end != share.end:
            what.append("keeps clear of them on its way to and from the work")
    if hold_s:
        what.append(f"lands after waiting {hold_s:g} s at its return layer")
    if layer_m:
        what.append(f"transits {layer_m:g} m above the work")
    if delay_s:
        what.append(f"start held {delay_s:g} s")
    return [
        f"separation: {' and '.join(what)} (as planned it would come within"
        f" {as_planned.horizontal_m:.1f} m of {_other(as_planned, share.drone_id)}"
        f" {as_planned.t_s:.0f} s after the start)"
    ]


def _place(
    options: Candidates,
    fixed: list[Trajectory],
    origin: LLA,
    *,
    delays: bool = True,
    holds: bool = True,
) -> tuple[Trajectory, float, float, float] | None:
    """The first candidate of rules 1-4 clear of ``fixed``: (path, delay, layer, hold)."""
    share = options.share
    layers = [layer for layer in LAYERS_M if options.allowed(layer)]
    first = flyable(options.path(0.0))[0]
    if first_hit(first, fixed, origin) is None:
        return first, 0.0, 0.0, 0.0
    hold = HOLD_STEP_S
    while holds and hold <= MAX_HOLD_S and is_layered_return(share.end):
        path = flyable(options.path(0.0, hold))[0]
        if first_hit(path, fixed, origin) is None:
            return path, 0.0, 0.0, hold
        hold += HOLD_STEP_S
    delay = 0.0
    while delay <= (MAX_DELAY_S if delays else 0.0):
        for layer in layers:
            path = flyable(options.path(layer))[0].delayed(delay)
            if (delay, layer) != (0.0, 0.0) and first_hit(path, fixed, origin) is None:
                return path, delay, layer, 0.0
        delay += DELAY_STEP_S
    return None


def _other(conflict: Conflict, me: str) -> str:
    return conflict.drone_b if conflict.drone_a == me else conflict.drone_a
