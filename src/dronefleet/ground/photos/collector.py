"""Fetches each picture a drone reports taking, and keeps it on the ground (issue 14).

A ground component with its own broker connection, as every other (seed Fig. 3.7). It hears the
Mission Planner's progress events; a ``takepic`` step reported with a capture record (position,
time, the drone's file name) is listed in the mission's pictures at once, and the picture is
asked of its drone with ``photo`` gear queries, one chunk at a time, one picture at a time (the
broker carries the flight first). A drone that does not answer is asked again every
:data:`RETRY_S` seconds, up to :data:`MAX_ATTEMPTS` times; a drone that says it has no such
picture, or sends something that is not one, is not asked again and the reason is listed. At
start, the pictures of every mission the planner keeps are listed and fetched if missing.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import secrets
from typing import Any

from pydantic import ValidationError

from dronefleet.errors import DronefleetError
from dronefleet.ground.photos.images import NotAPicture
from dronefleet.ground.photos.store import PhotoEntry, PhotoStore
from dronefleet.ground.planner.models import MissionRecord
from dronefleet.messaging.client import BrokerClient, BrokerUnavailable
from dronefleet.messaging.gear import GearQuery, GearRequest, PhotoChunk
from dronefleet.messaging.rpc import Requester, RequestTimeout
from dronefleet.messaging.topics import Channel, Direction, any_drone, topic

log = logging.getLogger(__name__)

RETRY_S = 10.0
MAX_ATTEMPTS = 30
CHUNK_TIMEOUT_S = 10.0
MAX_PICTURE_BYTES = 64 * 1024 * 1024  # a 50-megapixel JPEG is ~25 MB
NO_FILE = "the drone's camera kept no file of this picture"


class PictureRefused(DronefleetError):
    """The drone answered, but will not or cannot give the picture: not asked again."""


def captures(record: MissionRecord) -> list[PhotoEntry]:
    """Every picture the mission's drones reported, in report order (``n`` not yet given)."""
    found = []
    for leg in record.legs:
        for report in leg.reports:
            for shot, capture in enumerate(_shots(report.measured or {})):
                try:
                    found.append(
                        _entry(leg.leg_id, leg.drone_id, report.drone_step, report.index,
                               capture, shot)
                    )  # fmt: skip
                except (ValidationError, KeyError, TypeError):
                    log.warning(
                        "mission %s: a capture without a position: %s", record.mission_id, capture
                    )
    return found


def _shots(measured: dict[str, Any]) -> list[dict[str, Any]]:
    """A report's pictures: a takepic's capture, or the distance trigger's (ground/planner/
    measurements.py keeps only dicts)."""
    capture = measured.get("capture")
    return [capture] if isinstance(capture, dict) else list(measured.get("captures") or [])


def _entry(
    leg_id: str,
    drone_id: str,
    drone_step: int,
    step: int | None,
    c: dict[str, Any],
    shot: int = 0,
) -> PhotoEntry:
    file = c.get("file")
    name = file.replace("\\", "/").rsplit("/", 1)[-1] if isinstance(file, str) else ""
    named = bool(name)
    return PhotoEntry(
        n=0,
        drone_id=drone_id,
        leg_id=leg_id,
        drone_step=drone_step,
        shot=shot,
        step=step,
        lat=c["lat"],
        lon=c["lon"],
        alt_m=c.get("alt_m"),
        relative_alt_m=c.get("relative_alt_m"),
        vehicle_time_s=c.get("vehicle_time_s"),
        file=name or None,
        # A camera that keeps no file (an autopilot's, or a simulated drone without a log
        # folder) reports where it shot; there is no picture to fetch.
        error=None if named else NO_FILE,
        given_up=not named,
    )


class PhotoCollector:
    def __init__(
        self,
        broker_url: Any,
        planner: Any,  # the MissionPlanner: its records and its progress events
        store: PhotoStore,
        *,
        client_id: str | None = None,
        retry_s: float = RETRY_S,
    ) -> None:
        self.client = BrokerClient(broker_url, client_id or f"ground-photos-{secrets.token_hex(3)}")
        self.requester = Requester(self.client)
        self.planner = planner
        self.store = store
        self.retry_s = retry_s
        self._waiting: set[str] = set()  # missions with pictures to list or fetch
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

    async def start(self) -> PhotoCollector:
        await self.client.start()
        self.planner.add_listener(self._on_event)
        self._waiting.update(self.planner.missions)
        self._wake.set()
        self._task = asyncio.create_task(self._run(), name="ground:photos")
        return self

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task
        await self.client.stop()

    def _on_event(self, event: str, data: dict[str, Any]) -> None:
        result = data.get("result") or {}
        if event == "progress" and (
            isinstance(result.get("capture"), dict) or isinstance(result.get("captures"), list)
        ):
            self._waiting.add(str(data.get("mission_id")))
            self._wake.set()

    async def _run(self) -> None:
        while True:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self.retry_s):
                    await self._wake.wait()
            self._wake.clear()
            waiting, self._waiting = self._waiting, set()
            for mission_id in waiting:
                try:
                    if await self._collect(mission_id):
                        self._waiting.add(mission_id)  # some are still to fetch: try again
                except Exception:
                    log.exception("pictures of mission %s", mission_id)

    async def _collect(self, mission_id: str) -> bool:
        """List the mission's new pictures and fetch the missing ones; True if some are left."""
        record = self.planner.missions.get(mission_id)
        if record is None:
            return False
        await self.store.register(mission_id, captures(record))
        away: set[str] = set()  # drones that did not answer in this pass: asked next time
        left = False
        for entry in list(await self.store.entries(mission_id)):
            if entry.stored or entry.file is None or entry.given_up:
                continue
            if entry.drone_id in away:
                left = True
                continue
            left |= await self._fetch_one(mission_id, entry, away)
        return left

    async def _fetch_one(self, mission_id: str, entry: PhotoEntry, away: set[str]) -> bool:
        try:
            data = await self.fetch(entry.drone_id, entry.file or "")
            await self.store.keep(mission_id, entry.n, data)
            return False
        except (RequestTimeout, BrokerUnavailable) as exc:
            away.add(entry.drone_id)
            last = entry.attempts + 1 >= MAX_ATTEMPTS
            why = f"drone {entry.drone_id} did not answer: {exc}"
            await self.store.note_failure(mission_id, entry.n, why, give_up=last)
            return not last
        except (PictureRefused, NotAPicture) as exc:
            await self.store.note_failure(mission_id, entry.n, str(exc), give_up=True)
            return False

    async def fetch(self, drone_id: str, file: str) -> bytes:
        """The picture ``file`` from ``drone_id``, a chunk at a time."""
        data = bytearray()
        size: int | None = None
        while size is None or len(data) < size:
            try:
                request = GearRequest(query=GearQuery.PHOTO, photo=file, offset=len(data))
            except ValidationError:
                raise PictureRefused(f"picture {file!r} has a name no drone serves") from None
            answer = await self.requester.request(
                topic(drone_id, Channel.GEAR, Direction.IN),
                any_drone(Channel.GEAR),
                request,
                timeout_s=CHUNK_TIMEOUT_S,
                reply_topic=topic(drone_id, Channel.GEAR, Direction.OUT),
            )
            chunk = _chunk_of(drone_id, file, answer, offset=len(data))
            if size is not None and chunk.size_bytes != size:
                raise PictureRefused(f"picture {file} changed size on drone {drone_id} while sent")
            size = chunk.size_bytes
            if size > MAX_PICTURE_BYTES:
                raise PictureRefused(f"picture {file} is {size} B, over {MAX_PICTURE_BYTES} B")
            if not chunk.data and len(data) < size:
                raise PictureRefused(f"drone {drone_id} sent an empty part of {file}")
            data += chunk.data
        return bytes(data[:size])


def _chunk_of(drone_id: str, file: str, answer: dict[str, Any], *, offset: int) -> PhotoChunk:
    if not answer.get("ok"):
        raise PictureRefused(str(answer.get("error") or f"drone {drone_id} refused {file}"))
    try:
        chunk = PhotoChunk.model_validate(answer.get("photo"))
    except ValidationError as exc:
        raise PictureRefused(f"drone {drone_id} sent a malformed part of {file}: {exc}") from None
    if chunk.file != file or chunk.offset != offset:
        raise PictureRefused(
            f"drone {drone_id} sent another part than asked ({chunk.file}@{chunk.offset})"
        )
    return chunk
