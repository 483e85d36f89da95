"""The cheap changes of rules 2-4 (:mod:`.deconflict`): a landing held at its return layer
(:func:`held`), transits on a layer of their own (:func:`layered`), a start held back
(:func:`delayed`)."""

from __future__ import annotations

from typing import Any

from dronefleet.ground.planner.deconflict.shares import Share
from dronefleet.ground.planner.ends import is_layered_return
from dronefleet.messaging.commands import Command

#: Transit layers tried, metres above the work's height (0: as planned). 4 m apart: the 3 m
#: vertical minimum and a metre for the autopilot's altitude error.
LAYERS_M = (0.0, 4.0, 8.0, 12.0)
DELAY_STEP_S = 5.0
MAX_DELAY_S = 120.0
#: Waits at a return layer before coming down, tried in turn (landings in turn).
HOLD_STEP_S = 5.0
MAX_HOLD_S = 90.0


def _navigates(steps: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [s for s in steps if s.get("command") == Command.NAVIGATE]


def held(end: list[dict[str, Any]], hold_s: float) -> list[dict[str, Any]]:
    """A layered return that waits ``hold_s`` over home before its RTL."""
    if hold_s <= 0 or not is_layered_return(end):
        return end
    return [*end[:-2], {"command": Command.SLEEP.value, "value": hold_s}, *end[-2:]]


def layered(
    share: Share, layer_m: float, hold_s: float = 0.0
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]] | None:
    """The share's prefix and end with its transits ``layer_m`` higher (see the module doc),
    waiting ``hold_s`` at its return layer; None when its take-off is in its work (a step list
    that arms itself), not ours to change."""
    if layer_m <= 0:
        return [dict(s) for s in share.prefix], held([dict(s) for s in share.end], hold_s)
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
    if is_layered_return(share.end):  # a return layer of its own: that much higher
        for step in share.end:
            step = dict(step)
            if step.get("command") == Command.NAVIGATE and step.get("altitude_delta") is not None:
                step["altitude_delta"] = float(step["altitude_delta"]) + layer_m
            end.append(step)
        return prefix, held(end, hold_s)
    rtl_alt_m = share.vehicle.rtl_alt_m
    for step in share.end:
        if step.get("command") == Command.RTL and last is not None:
            height = float(last.get("altitude_delta") or 0.0)
            end += [
                {
                    "command": Command.NAVIGATE.value,
                    "lat": last["lat"],
                    "lon": last["lon"],
                    "altitude_delta": max(height, rtl_alt_m) + layer_m,
                },
                {"command": Command.WAIT_FOR_FLIGHT.value},
            ]
        end.append(dict(step))
    return prefix, end


def delayed(prefix: list[dict[str, Any]], delay_s: float) -> list[dict[str, Any]]:
    if delay_s <= 0:
        return prefix
    return [{"command": Command.SLEEP.value, "value": delay_s}, *prefix]


def highest_m(steps: list[dict[str, Any]]) -> float:
    key = {Command.NAVIGATE: "altitude_delta", Command.TAKEOFF: "value"}
    heights = [
        float(s[key[s["command"]]])
        for s in steps
        if s.get("command") in key and s.get(key[s["command"]]) is not None
    ]
    return max(heights, default=0.0)
