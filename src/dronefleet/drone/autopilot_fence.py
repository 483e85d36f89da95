"""The mission's geofence and rally points put on board a MAVLink autopilot before it flies
(issue 14), so the autopilot keeps to the fence and lands at a rally point by itself: when the
companion computer or its link is gone, in an on-board mission, in its own failsafes.

The drone keeps to the fence itself too (drone/fence_guard.py); this adds the autopilot's own
enforcement. Before the first step of a mission that carries them, the Mission Worker hands them
here; a backend with a ``mission`` facade (MAVLink) gets

- the fence as MAV_MISSION_TYPE_FENCE items: MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION for each
  corner of the inclusion polygon, _EXCLUSION for each exclusion zone's (param1: the polygon's
  corner count), and by PARAM_SET, each confirmed by its echo: on ArduPilot FENCE_TYPE (polygon,
  and max altitude when there is a ceiling), FENCE_ALT_MAX (the ceiling), FENCE_ENABLE 1; on PX4
  GF_MAX_VER_DIST (the ceiling);
- the rally points as MAV_MISSION_TYPE_RALLY items (MAV_CMD_NAV_RALLY_POINT, height above home).

Each list is read back and compared with what was sent: a fence the autopilot did not keep as
sent fails the mission before it flies, with the reason. A later mission without a fence or
rally points clears what this drone put there (FENCE_ENABLE 0), never a fence someone else set.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from dronefleet.messaging.fence import Geofence, RallyPoint
from dronefleet.vehicle.base import FcError

if TYPE_CHECKING:
    from dronefleet.protocols.mavlink.items import MissionItem

log = logging.getLogger(__name__)

#: ArduPilot's FENCE_TYPE bits.
FENCE_ALT_MAX_BIT = 1
FENCE_POLYGON_BIT = 4


def fence_items(fence: Geofence | None) -> list[MissionItem]:
    """The fence as MAV_MISSION_TYPE_FENCE items (inclusion polygon first)."""
    from dronefleet.protocols.mavlink import items as mi  # pymavlink: only for MAVLink drones

    if fence is None:
        return []
    zones = [(fence.inclusion, True)] if fence.inclusion else []
    zones += [(zone, False) for zone in fence.exclusions]
    return [
        mi.fence_vertex(lat, lon, len(zone), inclusion=inclusion)
        for zone, inclusion in zones
        for lat, lon in zone
    ]


def rally_items(points: list[RallyPoint]) -> list[MissionItem]:
    from dronefleet.protocols.mavlink import items as mi

    return [mi.rally_point(p.lat, p.lon, p.alt_m) for p in points]


def _same(sent: list[MissionItem], kept: list[MissionItem]) -> str | None:
    """Why ``kept`` (read back) is not ``sent``, or None."""
    from dronefleet.protocols.mavlink.codec import dialect as mav

    if len(kept) != len(sent):
        return f"the autopilot kept {len(kept)} of {len(sent)} items"
    for k, (a, b) in enumerate(zip(sent, kept, strict=True)):
        if (a.command, a.x, a.y, round(a.param1)) != (b.command, b.x, b.y, round(b.param1)):
            return f"item {k} reads back as command {b.command} at {b.lat:.7f}, {b.lon:.7f}"
        if a.command == mav.MAV_CMD_NAV_RALLY_POINT and abs(a.z - b.z) > 0.5:
            return f"item {k} reads back {b.z:g} m high, not {a.z:g} m"
    return None


class AutopilotFence:
    """What one drone put on board its autopilot, and the uploads that do it."""

    def __init__(self, fc: Any) -> None:
        self.fc = fc
        self.fence_on_board = False  # put there by this drone (cleared by a mission without)
        self.rally_on_board = False

    @property
    def supported(self) -> bool:
        return getattr(self.fc, "mission", None) is not None

    async def prepare(self, fence: Geofence | None, rally: list[RallyPoint]) -> dict[str, int]:
        """Put ``fence`` and ``rally`` on board (or clear ours); how many items of each.
        :class:`FcError` with the reason when the autopilot refuses or keeps something else."""
        from dronefleet.protocols.mavlink import items as mi

        done: dict[str, int] = {}
        if not self.supported:
            return done
        fence_list = fence_items(fence)
        if fence_list or self.fence_on_board or (fence and fence.ceiling_m):
            await self._transfer(fence_list, mi.FENCE, "geofence")
            await self._fence_params(fence)
            self.fence_on_board = bool(fence_list) or bool(fence and fence.ceiling_m)
            done["fence_items"] = len(fence_list)
        rally_list = rally_items(rally)
        if rally_list or self.rally_on_board:
            await self._transfer(rally_list, mi.RALLY, "rally points")
            self.rally_on_board = bool(rally_list)
            done["rally_items"] = len(rally_list)
        return done

    async def _transfer(self, items: list[MissionItem], kind: int, what: str) -> None:
        client = self.fc.mission
        await client.upload(items, mission_type=kind)
        why = _same(items, await client.download(kind))
        if why is not None:
            raise FcError(f"{what} upload not kept as sent: {why}")

    async def _fence_params(self, fence: Geofence | None) -> None:
        ceiling = fence.ceiling_m if fence is not None else None
        from dronefleet.protocols.mavlink.modes import Autopilot

        polygons = fence is not None and (fence.inclusion or fence.exclusions)
        if getattr(self.fc, "autopilot", None) is Autopilot.PX4:
            await self.fc.set_param("GF_MAX_VER_DIST", ceiling or 0.0)  # 0: no limit
            return
        kinds = (FENCE_ALT_MAX_BIT if ceiling else 0) | (FENCE_POLYGON_BIT if polygons else 0)
        if kinds:
            await self.fc.set_param("FENCE_TYPE", kinds)
        if ceiling:
            await self.fc.set_param("FENCE_ALT_MAX", ceiling)
        await self.fc.set_param("FENCE_ENABLE", 1 if kinds else 0)
        log.info(
            "autopilot fence: FENCE_TYPE %d, ceiling %s, enabled %s", kinds, ceiling, kinds > 0
        )
