"""Making a multi-drone plan keep its drones apart (issue 14), or refusing it with the reason.

Every plan the Mission Planner sends — shares of an area, a replacement, a collaborative
extension, the panic-button call — goes through :func:`separate` in the planning worker before
anything is sent. Each drone's share is predicted as a path in time (:mod:`.trajectory`) and
checked (:mod:`.separation`) against the traffic already in the air (the rest of every running
leg, drones hovering idle) and against the shares placed before it, in the plan's order.

The rule, cheapest first, for each share in turn:

1. as planned;
2. its transits on a layer of its own: the take-off climb and the way to its first work point
   flown :data:`LAYERS_M` above the work's height (it comes down onto the work there), and the
   way home (RTL) that much above the RTL height;
3. its start held back by :data:`DELAY_STEP_S`, twice that, ... up to :data:`MAX_DELAY_S` (a
   ``sleep`` before its first step: it waits on the ground, or hovers where it is), each delay
   tried on every layer.

A candidate conflicts when it comes within the minima of another path on time or with either
running :data:`~.separation.TIMING_SLACK_S` early or late. The first candidate that conflicts
with nothing is kept; the work itself (its waypoints, its
height, its photos) is never changed. If none does, the plan is refused with the first conflict
of the share as planned (both drones, the time and the place: a 422).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.estimate import VehicleModel
from dronefleet.ground.planner.separation import (
    Conflict,
    SeparationConflict,
    first_conflict_with_slack,
)
from dronefleet.ground.planner.trajectory import RTL_ALT_M, Trajectory, predict
from dronefleet.messaging.commands import Command

#: Transit layers tried, metres above the work's height (0: as planned). 4 m apart: the 3 m
#: vertical minimum and a metre for the autopilot's altitude error.
LAYERS_M = (0.0, 4.0, 8.0, 12.0)
DELAY_STEP_S = 5.0
MAX_DELAY_S = 120.0


@dataclass(frozen=True)
class Share:
    """One drone's steps as planned (``prefix`` + ``work`` + ``end``), from where it is now.

    Traffic (drones already flying something) is given as shares too, flown as they are."""

    drone_id: str
    prefix: list[dict[str, Any]]
    work: list[dict[str, Any]]
    end: list[dict[str, Any]]
    start: LLA
    home: LLA
    airborne: bool
    flight: dict[str, Any] | None = None  # Heartbeat.flight: how its vehicle flies

    @property
    def steps(self) -> list[dict[str, Any]]:
        return [*self.prefix, *self.work, *self.end]


@dataclass(frozen=True)
class Placed:
    """A share as it will be sent: its prefix and end (changed if it had to be), and why."""

    drone_id: str
    prefix: list[dict[str, Any]]
    end: list[dict[str, Any]]
    delay_s: float = 0.0
    layer_m: float = 0.0
    notes: list[str] = field(default_factory=list)


def _navigates(steps: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [s for s in steps if s.get("command") == Command.NAVIGATE]


def layered(
    share: Share, layer_m: float
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]] | None:
    """The share's prefix and end with its transits ``layer_m`` higher (see the module doc);
    None when its take-off is in its work (a step list that arms itself), not ours to change."""
    if layer_m <= 0:
        return [dict(s) for s in share.prefix], [dict(s) for s in share.end]
    if not share.airborne and not any(s.get("command") == Command.TAKEOFF for s in share.prefix):
        return None
    work_nav = _navigates(share.work)
    prefix: list[dict[str, Any]] = []
    for step in share.prefix:
        step = dict(step)
        if step.get("command") == Command.TAKEOFF and step.get("value") is not None:
            step["value"] = float(step["value"]) + layer_m
        elif step.get("command") == Command.NAVIGATE and step.get("altitude_delta") is not None:
            step["altitude_delta"] = float(step["altitude_delta"]) + layer_m
        prefix.append(step)
    first = work_nav[0] if work_nav else None
    if first is not None and not _navigates(prefix) and first.get("altitude_delta") is not None:
        # Climb and cross on the layer to above the first work point, then down onto it.
        prefix += [
            {
                "command": Command.NAVIGATE.value,
                "lat": first["lat"],
                "lon": first["lon"],
                "altitude_delta": float(first["altitude_delta"]) + layer_m,
            },
            {"command": Command.WAIT_FOR_FLIGHT.value},
        ]
    end: list[dict[str, Any]] = []
    last = work_nav[-1] if work_nav else None
    for step in share.end:
        if step.get("command") == Command.RTL and last is not None:
            height = float(last.get("altitude_delta") or 0.0)
            end += [
                {
                    "command": Command.NAVIGATE.value,
                    "lat": last["lat"],
                    "lon": last["lon"],
                    "altitude_delta": max(height, RTL_ALT_M) + layer_m,
                },
                {"command": Command.WAIT_FOR_FLIGHT.value},
            ]
        end.append(dict(step))
    return prefix, end


def _delayed(prefix: list[dict[str, Any]], delay_s: float) -> list[dict[str, Any]]:
    if delay_s <= 0:
        return prefix
    return [{"command": Command.SLEEP.value, "value": delay_s}, *prefix]


class _Candidates:
    """One share's paths per layer, predicted once each (a delay only shifts a path)."""

    def __init__(self, share: Share, origin: LLA) -> None:
        self.share = share
        self.origin = origin
        self.model = VehicleModel.of_vehicle(share.flight)
        self._paths: dict[float, tuple[Trajectory, list[dict[str, Any]], list[dict[str, Any]]]]
        self._paths = {}
        self.ceiling_m: float | None = None

    def allowed(self, layer_m: float) -> bool:
        """Whether the layer can be flown and stays below the ceiling."""
        found = self.path(layer_m)
        if found is None:
            return False
        return (
            not layer_m
            or self.ceiling_m is None
            or _highest_m([*found[1], *found[2]]) <= (self.ceiling_m)
        )

    def path(self, layer_m: float) -> tuple[Trajectory, list[dict[str, Any]], list[dict]] | None:
        """The path on ``layer_m`` with its prefix and end; None if that layer cannot be flown."""
        if layer_m not in self._paths:
            steps = layered(self.share, layer_m)
            if steps is None:
                return None
            prefix, end = steps
            s = self.share
            path = predict(
                s.drone_id, [*prefix, *s.work, *end], start=s.start, home=s.home,
                airborne=s.airborne, origin=self.origin, model=self.model,
            )  # fmt: skip
            self._paths[layer_m] = (path, prefix, end)
        return self._paths[layer_m]


def _first_hit(path: Trajectory, others: list[Trajectory], origin: LLA) -> Conflict | None:
    hits = [c for c in (first_conflict_with_slack(path, o, origin=origin) for o in others) if c]
    return min(hits, key=lambda c: c.t_s) if hits else None


def traffic_paths(traffic: list[Share], origin: LLA) -> list[Trajectory]:
    """The predicted paths of drones flown as they are."""
    return [
        predict(
            t.drone_id,
            t.steps,
            start=t.start,
            home=t.home,
            airborne=t.airborne,
            origin=origin,
            model=VehicleModel.of_vehicle(t.flight),
        )
        for t in traffic
    ]


def _highest_m(steps: list[dict[str, Any]]) -> float:
    key = {Command.NAVIGATE: "altitude_delta", Command.TAKEOFF: "value"}
    heights = [
        float(s[key[s["command"]]])
        for s in steps
        if s.get("command") in key and s.get(key[s["command"]]) is not None
    ]
    return max(heights, default=0.0)


def separate(
    shares: list[Share],
    traffic: list[Share],
    *,
    origin: LLA | None = None,
    ceiling_m: float | None = None,
) -> list[Placed]:
    """Each share placed so that no two drones come too close (the module's rule), in order.
    Layers that would climb above ``ceiling_m`` (the altitude limit, the fence's ceiling) are
    not tried.

    Raises :class:`SeparationConflict` naming both drones, the time and the place when a share
    cannot be separated. CPU work: callers run it in the planning worker."""
    if not shares:
        return []
    origin = origin or shares[0].home
    fixed = traffic_paths(traffic, origin)
    placed: list[Placed] = []
    for share in shares:
        options = _Candidates(share, origin)
        options.ceiling_m = ceiling_m
        layers = [layer for layer in LAYERS_M if options.allowed(layer)]
        first = _found(options.path(0.0))[0]
        as_planned = _first_hit(first, fixed, origin)
        chosen = None if as_planned else (first, 0.0, 0.0)
        delay = 0.0
        while chosen is None and delay <= MAX_DELAY_S:
            for layer in layers:
                path = _found(options.path(layer))[0].delayed(delay)
                if (delay, layer) != (0.0, 0.0) and _first_hit(path, fixed, origin) is None:
                    chosen = (path, delay, layer)
                    break
            delay += DELAY_STEP_S
        if chosen is None:
            assert as_planned is not None
            raise SeparationConflict(
                as_planned,
                f"neither a transit layer up to +{max(LAYERS_M):g} m nor a start delay up to"
                f" {MAX_DELAY_S:g} s keeps them apart",
            )
        path, delay_s, layer_m = chosen
        _, prefix, end = _found(options.path(layer_m))
        notes = []
        if as_planned is not None:
            what = []
            if layer_m:
                what.append(f"transits {layer_m:g} m above the work")
            if delay_s:
                what.append(f"start held {delay_s:g} s")
            notes.append(
                f"separation: {' and '.join(what)} (as planned it would come within"
                f" {as_planned.horizontal_m:.1f} m of {_other(as_planned, share.drone_id)}"
                f" {as_planned.t_s:.0f} s after the start)"
            )
        fixed.append(path)
        placed.append(
            Placed(share.drone_id, _delayed(prefix, delay_s), end, delay_s, layer_m, notes)
        )
    return placed


def _found(path: Any) -> Any:
    assert path is not None  # layers that cannot be flown are filtered out before
    return path


def _other(conflict: Conflict, me: str) -> str:
    return conflict.drone_b if conflict.drone_a == me else conflict.drone_a
