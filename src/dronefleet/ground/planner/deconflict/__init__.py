"""Making a multi-drone plan keep its drones apart (issue 14), or refusing it with the reason.

Every plan the Mission Planner sends — shares of an area, a replacement, a collaborative
extension, the panic-button call — goes through :func:`separate` in the planning worker before
anything is sent. Each drone's share is predicted as a path in time (:mod:`.trajectory`) and
checked (:mod:`.separation`) against the traffic already in the air (the rest of every running
leg, drones hovering idle) and against the shares placed before it, in the plan's order.

The rule, cheapest first, for each share in turn:

1. as planned;
2. a way home flown on a return layer of its own (ground/planner/ends.py): its landing held
   :data:`HOLD_STEP_S`, twice that, ... up to :data:`MAX_HOLD_S` at its layer over home (a
   ``sleep`` before its RTL: it comes down once the drone landing near its home is down);
3. its transits on a layer of its own: the take-off climb and the way to its first work point
   flown :data:`LAYERS_M` above the work's height (it comes down onto the work there), and the
   way home (RTL) that much above the RTL height, or above its return layer;
4. its start held back by :data:`DELAY_STEP_S`, twice that, ... up to :data:`MAX_DELAY_S` (a
   ``sleep`` before its first step: it waits on the ground, or hovers where it is), each delay
   tried on every layer.

5. (only for a caller that sends the work as changed here: a replacement) near a lost drone
   (ground/planner/orphans.py: kept :data:`~.orphans.MIN_RADIUS_M` and more clear, forever,
   until the ground hears it again; neither a layer for the transits nor a delay helps), its
   steps within the orphan's keep-out flown :data:`AROUND_M` above or below it, the way to it
   dropped (straight to the first work point), the keep-out widened by
   :data:`AROUND_MARGINS_M` in turn until the way down to the work's height starts clear of it
   (:func:`around`).

A candidate conflicts when it comes within the minima of another path on time or with either
running :data:`~.separation.TIMING_SLACK_S` early or late. The first candidate that conflicts
with nothing is kept; the work itself (its waypoints, its height, its photos) is never changed
but by rule 5. If none does, the plan is refused with the first conflict of the share as
planned (both drones, the time and the place: a 422).

The parts: the shares (:mod:`.shares`), rules 2-4's changes (:mod:`.layers`), the paths tried
(:mod:`.candidates`), the placing (:mod:`.place`), rule 5 (:mod:`.around`, :mod:`.ways`).
"""

from __future__ import annotations

from dronefleet.ground.planner.deconflict.around import AROUND_MARGINS_M, around
from dronefleet.ground.planner.deconflict.candidates import traffic_paths
from dronefleet.ground.planner.deconflict.layers import (
    DELAY_STEP_S,
    HOLD_STEP_S,
    LAYERS_M,
    MAX_DELAY_S,
    MAX_HOLD_S,
    held,
    layered,
)
from dronefleet.ground.planner.deconflict.place import separate
from dronefleet.ground.planner.deconflict.shares import Placed, Share
from dronefleet.ground.planner.deconflict.ways import AROUND_FLOOR_M, AROUND_M

__all__ = [
    "AROUND_FLOOR_M",
    "AROUND_M",
    "AROUND_MARGINS_M",
    "DELAY_STEP_S",
    "HOLD_STEP_S",
    "LAYERS_M",
    "MAX_DELAY_S",
    "MAX_HOLD_S",
    "Placed",
    "Share",
    "around",
    "held",
    "layered",
    "separate",
    "traffic_paths",
]
