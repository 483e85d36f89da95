"""Experiment results: per-stage timings beside the seed's figures and the kinematic bounds."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

#: The seed's flights (chapter 5) and the bounds of docs/DESIGN.md §10, in vehicle seconds.
SEED = {"panic": 25.0, "survey": 331.0, "replacement": None, "collab": 154.0}
BOUND = {"panic": 17.0, "survey": 76.0, "replacement": 16.8, "collab": 107.0}
TARGET = {
    "panic": "total <= 19 s",
    "survey": "fly-through total <= 1.2 x 76 s = 91.2 s",
    "replacement": "gap with early launch <= 2 s",
    "collab": "makespan <= 0.8 x seed baseline",
}


@dataclass
class Result:
    experiment: str
    strategy: str
    total_s: float
    stages: dict[str, float] = field(default_factory=dict)
    waypoints_planned: int = 0
    waypoints_reached: int = 0
    gap_s: float | None = None
    mission_id: str = ""
    notes: dict[str, Any] = field(default_factory=dict)
    #: The ground's separation monitor over the run (ground/separation_monitor.py): encounters
    #: predicted and actual, the closest approaches in metres.
    separation: dict[str, Any] = field(default_factory=dict)

    def as_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["seed_s"] = SEED[self.experiment]
        data["bound_s"] = BOUND[self.experiment]
        return data

    def table(self) -> str:
        rows = [
            f"{self.experiment} ({self.strategy} strategy), mission {self.mission_id}",
            f"  {'stage':<34}{'vehicle s':>10}",
        ]
        rows += [f"  {name:<34}{seconds:>10.1f}" for name, seconds in self.stages.items()]
        rows.append(f"  {'total':<34}{self.total_s:>10.1f}")
        if self.gap_s is not None:
            rows.append(f"  {'handover gap':<34}{self.gap_s:>10.1f}")
        seed = SEED[self.experiment]
        rows.append(
            f"  seed (real flight): {'n/a' if seed is None else f'{seed:g} s'}; "
            f"kinematic bound: {BOUND[self.experiment]:g} s; target: {TARGET[self.experiment]}"
        )
        rows.append(f"  waypoints reached: {self.waypoints_reached}/{self.waypoints_planned}")
        rows += [f"  {k}: {v}" for k, v in self.notes.items()]
        if self.separation:
            rows.append(f"  {separation_line(self.separation)}")
        return "\n".join(rows)


def separation_line(figures: dict[str, Any]) -> str:
    """The separation monitor's figures in one line."""

    def metres(value: float | None) -> str:
        return "n/a (never two in the air)" if value is None else f"{value:.1f} m"

    return (
        f"separation: {figures.get('predicted_breaches', 0)} predicted /"
        f" {figures.get('actual_breaches', 0)} actual breaches; closest approach"
        f" {metres(figures.get('min_distance_m'))}, horizontally within"
        f" {figures.get('vertical_m', 3.0):g} m of height {metres(figures.get('min_horizontal_m'))}"
    )
