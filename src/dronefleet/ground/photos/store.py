"""The pictures of each mission in the ground's state folder: files, not database blobs.

``<photo_dir>/<mission_id>/`` holds each picture as the drone sent it (``0001_QUAD_1.jpg``),
its thumbnail (``thumbs/0001.jpg``), ``photos.json`` (the list: where, when, which step, whether
the picture is here yet) and, once asked for, ``photos.zip``. A picture gets its number when its
``takepic`` is first reported and keeps it, whatever order the pictures arrive in. Files are
read and written on worker threads; the list is kept in memory once read.
"""

from __future__ import annotations

import asyncio
import re
from pathlib import Path

from pydantic import BaseModel, Field, ValidationError

from dronefleet.errors import InvalidInput, NotFound, Unavailable
from dronefleet.ground.photos import images
from dronefleet.owner_only import write_private

SAFE_ID = re.compile(r"^[A-Za-z0-9_-]{1,64}$")
MANIFEST = "photos.json"


class PhotoEntry(BaseModel):
    """One picture of a mission: where and when it was taken, and whether the ground has it."""

    n: int = Field(description="the picture's number in its mission, from 1")
    drone_id: str
    leg_id: str
    drone_step: int = Field(description="the step in the drone's own list")
    shot: int = Field(
        default=0, description="which of the pictures its step reported (distance trigger)"
    )
    step: int | None = Field(description="the mission's step (None: not a work step)")
    lat: float
    lon: float
    alt_m: float | None = None
    relative_alt_m: float | None = None
    vehicle_time_s: float | None = None
    file: str | None = Field(default=None, description="the picture's name on the drone")
    stored: bool = Field(default=False, description="the picture is on the ground")
    size_bytes: int | None = None
    error: str | None = Field(default=None, description="why the picture is not on the ground")
    attempts: int = 0
    given_up: bool = Field(default=False, description="the ground no longer asks the drone")

    @property
    def key(self) -> tuple[str, int, int]:
        return self.leg_id, self.drone_step, self.shot

    @property
    def name(self) -> str:
        """Its file name on the ground (and in the zip): number and drone, for photogrammetry
        tools that take a folder of pictures."""
        return f"{self.n:04d}_{self.drone_id}.jpg"


class _Manifest(BaseModel):
    photos: list[PhotoEntry] = Field(default_factory=list)


class PhotoStore:
    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)
        self._lists: dict[str, list[PhotoEntry]] = {}
        self._zipped: dict[str, list[int]] = {}  # mission -> the pictures its zip holds
        self._lock = asyncio.Lock()

    def folder(self, mission_id: str) -> Path:
        if not SAFE_ID.match(mission_id):
            raise InvalidInput(f"mission id {mission_id!r} cannot name a folder")
        return self.root / mission_id

    async def entries(self, mission_id: str) -> list[PhotoEntry]:
        found = self._lists.get(mission_id)
        if found is None:
            path = self.folder(mission_id) / MANIFEST
            text = await asyncio.to_thread(_read_text, path)
            try:
                found = _Manifest.model_validate_json(text).photos if text else []
            except ValidationError as exc:  # the file was damaged or edited: never a 500
                raise Unavailable(
                    f"the picture list of mission {mission_id} ({path}) cannot be read "
                    f"({exc.errors()[0]['msg']}); the pictures are in its folder: mend or "
                    f"remove {MANIFEST} and the ground lists what the drones report again"
                ) from exc
            self._lists[mission_id] = found
        return found

    async def entry(self, mission_id: str, n: int) -> PhotoEntry:
        for entry in await self.entries(mission_id):
            if entry.n == n:
                return entry
        raise NotFound(f"mission {mission_id} has no picture {n}")

    async def register(self, mission_id: str, new: list[PhotoEntry]) -> list[PhotoEntry]:
        """Number the pictures not listed yet (``n`` is set here) and list them."""
        async with self._lock:
            listed = await self.entries(mission_id)
            known = {e.key for e in listed}
            added = []
            for entry in new:
                if entry.key in known:
                    continue
                known.add(entry.key)
                added.append(entry.model_copy(update={"n": len(listed) + 1}))
                listed.append(added[-1])
            if added:
                await self._save(mission_id)
            return added

    async def keep(self, mission_id: str, n: int, data: bytes) -> PhotoEntry:
        """Keep picture ``n`` as sent, with its thumbnail; raises NotAPicture for junk."""
        entry = await self.entry(mission_id, n)
        folder = self.folder(mission_id)
        await asyncio.to_thread(_write_picture, folder, entry.name, n, data)
        async with self._lock:
            entry.stored, entry.size_bytes, entry.error = True, len(data), None
            await self._save(mission_id)
        return entry

    async def note_failure(
        self, mission_id: str, n: int, reason: str, *, give_up: bool = False
    ) -> None:
        async with self._lock:
            entry = await self.entry(mission_id, n)
            entry.error, entry.attempts = reason, entry.attempts + 1
            entry.given_up = give_up
            await self._save(mission_id)

    def picture_path(self, mission_id: str, entry: PhotoEntry) -> Path:
        return self.folder(mission_id) / entry.name

    def thumb_path(self, mission_id: str, entry: PhotoEntry) -> Path:
        return self.folder(mission_id) / "thumbs" / f"{entry.n:04d}.jpg"

    async def zip_path(self, mission_id: str) -> Path:
        """``photos.zip`` with every picture the ground has; rebuilt when one was added."""
        stored = [e for e in await self.entries(mission_id) if e.stored]
        if not stored:
            raise NotFound(f"mission {mission_id} has no pictures on the ground yet")
        dest = self.folder(mission_id) / "photos.zip"
        numbers = [e.n for e in stored]
        if self._zipped.get(mission_id) != numbers or not dest.exists():
            files = [(e.name, self.picture_path(mission_id, e)) for e in stored]
            await asyncio.to_thread(images.write_zip, files, dest)
            self._zipped[mission_id] = numbers
        return dest

    async def _save(self, mission_id: str) -> None:
        text = _Manifest(photos=self._lists[mission_id]).model_dump_json(indent=1)
        await asyncio.to_thread(_write_text, self.folder(mission_id) / MANIFEST, text)


def _read_text(path: Path) -> str | None:
    try:
        return path.read_text()
    except FileNotFoundError:
        return None


def _write_text(path: Path, text: str) -> None:
    write_private(path, text.encode())  # the owner's only, folders too (issue 25)


def _write_picture(folder: Path, name: str, n: int, data: bytes) -> None:
    small = images.thumbnail(data)  # first: junk is refused before anything is written
    for path, content in ((folder / name, data), (folder / "thumbs" / f"{n:04d}.jpg", small)):
        write_private(path, content)
