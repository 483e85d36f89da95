"""The paths a share is tried on (:class:`Candidates`: one per layer and hold, predicted once)
and the paths of the traffic it must keep clear of (:func:`traffic_paths`)."""

from __future__ import annotations

from typing import Any

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.deconflict.layers import highest_m, layered
from dronefleet.ground.planner.deconflict.shares import Share
from dronefleet.ground.planner.separation import Conflict, first_conflict_with_slack
from dronefleet.ground.planner.trajectory import Trajectory, predict


class Candidates:
    """One share's paths per layer, predicted once each (a delay only shifts a path)."""

    def __init__(self, share: Share, origin: LLA, ceiling_m: float | None = None) -> None:
        self.share = share
        self.origin = origin
        self.model = share.vehicle
        self._paths: dict[
            tuple[float, float], tuple[Trajectory, list[dict[str, Any]], list[dict[str, Any]]]
        ] = {}
        self.ceiling_m = ceiling_m

    def allowed(self, layer_m: float) -> bool:
        """Whether the layer can be flown and stays below the ceiling."""
        found = self.path(layer_m)
        if found is None:
            return False
        return (
            not layer_m
            or self.ceiling_m is None
            or highest_m([*found[1], *found[2]]) <= (self.ceiling_m)
        )

    def path(
        self, layer_m: float, hold_s: float = 0.0
    ) -> tuple[Trajectory, list[dict[str, Any]], list[dict]] | None:
        """The path on ``layer_m`` (waiting ``hold_s`` at its return layer) with its prefix and
        end; None if that layer cannot be flown."""
        key = (layer_m, hold_s)
        if key not in self._paths:
            steps = layered(self.share, layer_m, hold_s)
            if steps is None:
                return None
            prefix, end = steps
            s = self.share
            path = predict(
                s.drone_id, [*prefix, *s.work, *end], start=s.start, home=s.home,
                airborne=s.airborne, origin=self.origin, model=self.model,
            )  # fmt: skip
            self._paths[key] = (path, prefix, end)
        return self._paths[key]


def first_hit(path: Trajectory, others: list[Trajectory], origin: LLA) -> Conflict | None:
    hits = [c for c in (first_conflict_with_slack(path, o, origin=origin) for o in others) if c]
    return min(hits, key=lambda c: c.t_s) if hits else None


def traffic_paths(traffic: list[Share], origin: LLA) -> list[Trajectory]:
    """The predicted paths of drones flown as they are; a lost drone's keep-out as paths that
    carry it (:meth:`.orphans.Orphan.paths`)."""
    paths: list[Trajectory] = []
    for t in traffic:
        if t.orphan is not None:
            paths += t.orphan.paths(origin)
            continue
        paths.append(
            predict(
                t.drone_id,
                t.steps,
                start=t.start,
                home=t.home,
                airborne=t.airborne,
                origin=origin,
                model=t.vehicle,
            )
        )
    return paths


def flyable(path: Any) -> Any:
    assert path is not None  # layers that cannot be flown are filtered out before
    return path
