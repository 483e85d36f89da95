"""What the separation check places (:class:`Share`: one drone's steps from where it is now,
traffic included) and what it sends back (:class:`Placed`: the share as it will be flown)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.estimate import VehicleModel
from dronefleet.ground.planner.orphans import Orphan


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
    #: How it flies, in the wind of the plan (estimate.vehicle_model); else from ``flight``.
    model: VehicleModel | None = None
    #: Traffic only: a lost drone, kept clear of where it was (ground/planner/orphans.py).
    orphan: Orphan | None = None

    @property
    def steps(self) -> list[dict[str, Any]]:
        return [*self.prefix, *self.work, *self.end]

    @property
    def vehicle(self) -> VehicleModel:
        return self.model or VehicleModel.of_vehicle(self.flight)


@dataclass(frozen=True)
class Placed:
    """A share as it will be sent: its prefix and end (changed if it had to be), and why."""

    drone_id: str
    prefix: list[dict[str, Any]]
    end: list[dict[str, Any]]
    delay_s: float = 0.0
    layer_m: float = 0.0
    notes: list[str] = field(default_factory=list)
    hold_s: float = 0.0  # waited at its return layer before coming down
    #: Its work as it must fly it, when that changed (steps near a lost drone on another
    #: layer: :func:`around`); None: as given. Only with ``separate(alter_work=True)``.
    work: list[dict[str, Any]] | None = None
