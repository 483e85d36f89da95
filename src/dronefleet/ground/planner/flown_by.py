"""Who flies a share: the autopilot on board, or the drone's companion computer, and why not on
board (``options.onboard``: ground/planner/options.py)."""

from __future__ import annotations

from dronefleet.ground.planner.deconflict import Share
from dronefleet.ground.planner.mission_spec import MissionSpec
from dronefleet.ground.planner.service import PlannerError
from dronefleet.protocols.mavlink.items import onboard_refusal


def flown_by(
    spec: MissionSpec, drone_id: str, share: Share, indices: list[int]
) -> tuple[str | None, str | None]:
    """Who flies ``share`` (``autopilot`` on board, ``companion`` from the companion computer,
    None: as the drone is configured) and why not on board; a share asked on board
    (``options.onboard``) that cannot be flown there is refused naming its step."""
    if spec.options.onboard is False:
        return "companion", "the mission asks to be flown from the companion computer"
    found = onboard_refusal([str(s.get("command")) for s in share.steps])
    if found is None:
        return ("autopilot", None) if spec.options.onboard else (None, None)
    k, why = found
    first = len(share.prefix)
    if k < first:
        where = f"its preparation step {share.prefix[k]['command']}"
    elif k < first + len(indices):
        where = f"step {indices[k - first]} ({share.steps[k]['command']})"
    else:
        where = f"its end step {share.steps[k]['command']}"
    if spec.options.onboard:
        raise PlannerError(
            f"drone {drone_id} cannot fly its share on board the autopilot, as the mission"
            f" asks (options.onboard): {where}: {why}"
        )
    return (
        "companion",
        f"{where}: {why}; a drone set to fly missions on board flies it from its companion"
        " computer",
    )
