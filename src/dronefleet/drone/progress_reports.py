"""The Mission Worker's progress reports on ``mission/out`` (seed 4.1.2.3): each one built where
the vehicle is and at its time, and a mission's reports sent again, in order, when the ground asks
for them (issue 13; drone/report_history.py numbers and keeps them).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from dronefleet.drone.state import position_of
from dronefleet.messaging.missions import MissionProgress, ProgressEvent
from dronefleet.messaging.topics import Channel

if TYPE_CHECKING:
    from dronefleet.drone.controller import DroneController
    from dronefleet.drone.mission_worker import MissionWorker


def progress(
    controller: DroneController, event: ProgressEvent, mission_id: str, **fields: Any
) -> MissionProgress:
    """A report of ``event`` with the vehicle's position and time (step times to the ms)."""
    fc = controller.fc
    for key in ("step_started_s", "step_duration_s"):
        if fields.get(key) is not None:
            fields[key] = round(fields[key], 3)
    return MissionProgress(
        drone_id=controller.drone_id,
        mission_id=mission_id,
        event=event,
        position=position_of(fc.position(), fc.home()),
        vehicle_time_s=round(controller.clock.now(), 3),
        **fields,
    )


async def replay(worker: MissionWorker, mission_id: str, request_id: str | None) -> None:
    """Re-send every report of ``mission_id``, in order; readers drop the duplicates."""
    kept = worker.reports.replay(mission_id)
    if kept is None:
        return  # just re-sent: a burst of requests gets one replay
    if not kept:
        await worker.report(
            ProgressEvent.REJECTED,
            mission_id,
            request_id=request_id,
            ok=False,
            error=f"no reports kept for mission {mission_id!r}",
        )
        return
    for report in kept:
        worker.outbox.post(worker.controller.topic(Channel.MISSION), report)
    # After its reports, in order: the rest is not flown.
    if mission_id in worker.reports.interrupted:
        fc = worker.controller.fc
        said = MissionProgress(
            drone_id=worker.controller.drone_id,
            mission_id=mission_id,
            request_id=request_id,
            event=ProgressEvent.REJECTED,
            ok=False,
            error="interrupted: the drone software restarted while flying it; its reports "
            "were sent again, the rest is not flown",
            position=position_of(fc.position(), fc.home()),
            vehicle_time_s=round(worker.clock.now(), 3),
        )
        worker.outbox.post(worker.controller.topic(Channel.MISSION), said)
