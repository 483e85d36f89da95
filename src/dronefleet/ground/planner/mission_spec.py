"""What a person (or the web planner) asks for, and its work steps (REST: ``/api/v1/missions``).

A mission is given as steps (the seed's commands) or as an area (coverage). Its steps are
validated one by one and none may go above the altitude limit; an area is planned (coverage)
here too. ground/planner/shares.py then shares the work among the drones and checks each share.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from pydantic import BaseModel, ConfigDict, Field, field_validator

from dronefleet.ground.planner.bounds import AreaRequest
from dronefleet.ground.planner.coverage import AreaSpec, plan_area
from dronefleet.ground.planner.options import MissionOptions
from dronefleet.ground.planner.service import PlannerError
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.commands import Command, parse_step

if TYPE_CHECKING:
    # Code may give any AreaSpec; MissionSpec re-checks it against the request bounds.
    AreaField = AreaSpec | None
else:
    AreaField = AreaRequest | None  # what a request is validated (and documented) as


class MissionSpec(BaseModel):
    """What a person (or the web planner) asks for."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(default="", max_length=200)
    mission_id: str | None = Field(default=None, pattern=r"^[A-Za-z0-9_\-]{1,64}$")
    drones: list[str] = Field(default_factory=list, max_length=50)
    steps: list[dict[str, Any]] | None = Field(default=None, max_length=10_000)
    area: AreaField = None
    options: MissionOptions = Field(default_factory=MissionOptions)

    @field_validator("area", mode="before")
    @classmethod
    def _bounded(cls, value: object) -> object:
        """An AreaSpec built in code is checked against the request bounds too."""
        if isinstance(value, AreaSpec) and not isinstance(value, AreaRequest):
            return value.model_dump()
        return value


def _plan(area: AreaSpec) -> Any:
    """The coverage plan of ``area``; the coverage planner's refusals (ValueError: a polygon that
    is not simple or has no area, a hole outside it, too many waypoints...) are the caller's
    input that cannot be planned, so a 422 with the planner's reason."""
    try:
        return plan_area(area)
    except ValueError as exc:
        raise PlannerError(f"area: {exc}") from exc


def work_of(spec: MissionSpec) -> tuple[list[dict[str, Any]], Any]:
    """The work steps (validated) and the coverage plan (for areas).

    An area alone gives its generated steps; steps alone are flown as given; both together fly
    the given steps (an edited waypoint list) and keep the area for a collaborative extension.
    """
    if spec.steps is None and spec.area is None:
        raise PlannerError("give 'steps', 'area', or both")
    plan = _plan(spec.area) if spec.area is not None else None
    if spec.steps is None:
        assert plan is not None  # an area was given
        return plan.mission_steps(), plan
    steps = []
    for i, step in enumerate(spec.steps):
        try:
            steps.append(parse_step(step).model_dump(mode="json", exclude_none=True))
        except MessageError as exc:
            raise PlannerError(f"step {i}: {exc}") from exc
    if not steps:
        raise PlannerError("a mission needs at least one step")
    return steps, plan


def check_altitudes(work: list[dict[str, Any]], limit_m: float) -> None:
    for i, step in enumerate(work):
        height = step.get("altitude_delta") if step.get("command") == Command.NAVIGATE else None
        if step.get("command") == Command.TAKEOFF:
            height = step.get("value")
        if height is not None and height > limit_m:
            raise PlannerError(
                f"step {i} ({step['command']}) goes to {height:g} m, above the {limit_m:g} m limit"
            )


def self_prepared(work: list[dict[str, Any]]) -> bool:
    """A step list that arms and takes off by itself needs no preparation prefix."""
    return any(s.get("command") in (Command.ARM, Command.TAKEOFF) for s in work)
