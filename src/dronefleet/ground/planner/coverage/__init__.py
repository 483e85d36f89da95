"""Area coverage for the Mission Planner (seed 4.2.4 "mapping", Figures 4.27-4.28, chapter 5).

An :class:`AreaSpec` (polygon with holes, spacing or camera, height, angle, action, fly-through)
goes through the :class:`CoveragePipeline` stages and comes out as a :class:`CoveragePlan`:
waypoints and the mission steps that fly them. :func:`rebuild` and :func:`seed_grid_rebuild`
regenerate a task with a new centre and a larger area (the seed's extensibility parameters).
"""

from dronefleet.ground.planner.coverage.extend import (
    area_m2,
    collaboration_factor,
    extensibility_parameters,
    rebuild,
    seed_grid_rebuild,
)
from dronefleet.ground.planner.coverage.path import Kind
from dronefleet.ground.planner.coverage.pipeline import CoveragePipeline, plan_area
from dronefleet.ground.planner.coverage.plan import CoveragePlan
from dronefleet.ground.planner.coverage.spec import Action, AreaSpec, CameraSpec, Grid

__all__ = [
    "Action",
    "AreaSpec",
    "CameraSpec",
    "CoveragePipeline",
    "CoveragePlan",
    "Grid",
    "Kind",
    "area_m2",
    "collaboration_factor",
    "extensibility_parameters",
    "plan_area",
    "rebuild",
    "seed_grid_rebuild",
]
