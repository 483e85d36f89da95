"""A mission whose step fails leaves its drone safe (issue 28, item 7).

Measured on PX4 SITL: a photo step on a vehicle without a camera failed with the reason, and the
vehicle was left hovering where the step failed, its mission ``failed`` and nobody flying it; the
simulator and ArduPilot did the same for any step failing in the air. Every share the planner
sends ends with the mission's end action (ground/planner/ends.py): ``rtl`` or ``land`` and a
``wait_for_flight``, or nothing for ``hold``. When a step fails with the vehicle in the air, the
Mission Worker now flies that end at once (:func:`fly_the_end`), before it reports the failure:
the first ``rtl`` or ``land`` among the steps left (as written: an RTL to a rally point stays
one), else it holds where it is (``hold`` is the end asked for, and an operator's own steps
without an end are theirs to finish). The autopilot flies the return by itself; the failure
report says what the drone does.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from typing import Any

from dronefleet.drone.controller import CommandError, DroneController
from dronefleet.messaging.commands import Command
from dronefleet.vehicle.base import FcError

log = logging.getLogger(__name__)

_ENDS = frozenset({Command.RTL, Command.LAND})


def end_of(left: Iterable[tuple[int, Any]]) -> Any | None:
    """The mission's end among the steps ``left`` (index, step): its first rtl or land."""
    return next((step for _, step in left if step.command in _ENDS), None)


async def fly_the_end(controller: DroneController, left: Iterable[tuple[int, Any]]) -> str | None:
    """Make the vehicle safe after a failed step: the mission's end flown (``rtl``, ``land``) or
    a hold; what it did, for the failure report (None on the ground: nothing to do)."""
    state = controller.fc.state()
    if not (state.armed and state.in_air):
        return None
    end = end_of(left)
    what = "the mission's end" if end is not None else "no end left to fly"
    try:
        if end is None:
            await controller.navigation.hold()
            done = f"holding where it is ({what})"
        else:
            await controller.execute(end)
            done = f"flying {what}: {end.command}"
    except (CommandError, FcError) as exc:
        log.error("%s: could not make the vehicle safe after a failed step: %s",
                  controller.drone_id, exc)  # fmt: skip
        return f"its end ({end.command if end else 'hold'}) refused: {exc}"
    log.warning("%s: a step failed in the air; %s", controller.drone_id, done)
    return done
