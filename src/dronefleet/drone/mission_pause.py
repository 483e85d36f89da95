"""A mission paused and resumed (issue 10): when a takeover (drone/takeover.py), the operator's
pause, a direct command or a lost autopilot link (issue 26) stops the mission the Mission Worker
flies (drone/mission_worker.py), what is left of it is kept and reported ``paused``; the
operator's resume takes the vehicle back, on to the goal it was flying to, and flies the steps
not done.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from dronefleet.drone.controller import CommandError
from dronefleet.drone.takeover import LINK_LOST, Paused, Takeover
from dronefleet.messaging.missions import ProgressEvent
from dronefleet.vehicle.base import FcError

if TYPE_CHECKING:
    from dronefleet.drone.controller import DroneController
    from dronefleet.drone.mission_worker import MissionWorker

log = logging.getLogger(__name__)


def link_lost(controller: DroneController) -> Takeover | None:
    """The autopilot's link lost (its backend says so after its heartbeat timeout, 3 s on
    MAVLink): a pause, looked at with the takeovers (issue 26)."""
    fc = controller.fc
    if getattr(fc, "connected", True):
        return None
    why = "no heartbeat from the autopilot; resume once it is back, or abort"
    return Takeover("unknown", LINK_LOST, why, round(controller.clock.now(), 3))


async def pause(
    worker: MissionWorker, mission_id: str, count: int, start_index: int, taken: Takeover
) -> None:
    """Pause the mission ``taken`` over: what is left of it kept, reported ``paused``."""
    await worker.controller.camera_trigger.stop()
    nav = worker.controller.navigation
    paused = Paused(
        mission_id, count, start_index, worker.steps, set(worker.steps_done), taken,
        nav.goal, nav.landing,
    )  # fmt: skip
    worker.paused = paused
    left = paused.left()
    log.warning("%s: mission %s %s", worker.controller.drone_id, mission_id, taken.describe())
    await worker.report(
        ProgressEvent.PAUSED,
        mission_id,
        step_index=left[0][0] if left else None,
        step_count=count,
        error=taken.describe(),
        result=taken.fields(),
    )


async def resume(
    worker: MissionWorker, mission_id: str, request_id: str | None
) -> tuple[Paused, list[tuple[int, Any]]] | None:
    """Fly on with a paused mission: take the vehicle back (on to its goal), then the steps
    not done, from the companion computer. Refused (still paused) on the ground: None, else the
    mission paused and the steps to fly, for the worker to run."""
    paused = worker.paused
    if paused is None or paused.mission_id != mission_id:
        await worker.report(
            ProgressEvent.REJECTED,
            mission_id,
            request_id=request_id,
            ok=False,
            error=f"mission {mission_id!r} is not paused on this drone",
        )
        return None
    state = worker.controller.fc.state()
    left, why, to_goal = paused.resume_plan(grounded=not (state.armed and state.in_air))
    nav = worker.controller.navigation
    if why is None and to_goal and paused.goal is not None and nav.goal != paused.goal:
        nav.goal, nav.landing = paused.goal, paused.landing  # moved by a direct command
    if why is None and to_goal:
        try:
            await worker.controller.navigation.resume()
        except (CommandError, FcError) as exc:
            why = str(exc)
    if why is not None:
        await worker.report(
            ProgressEvent.PAUSED,
            mission_id,
            request_id=request_id,
            ok=False,
            error=f"resume refused: {why}; still {paused.takeover.describe()}",
            result=paused.takeover.fields(),
        )
        return None
    worker.paused = None
    worker.controller.navigation.modes.adopt()  # the steps left take it from here
    await worker.report(
        ProgressEvent.RESUMED,
        mission_id,
        request_id=request_id,
        step_index=left[0][0] if left else None,
        step_count=paused.count,
    )
    return paused, left
