"""The pictures this drone's camera wrote, served to the ground in chunks (issue 14).

Part of the Gear Manager (seed 3.3.2.3): a ``takepic`` reports where the picture was taken (the
capture record, with the ``file`` the camera wrote); the ground then asks for the picture itself
with ``photo`` gear queries, a chunk at a time (messaging/gear.py). Only files this camera wrote
since the drone started are served, by their name: a request cannot name any other file on the
companion computer. The newest :data:`KEPT` names are remembered; files are read on a worker
thread, so a slow card never stalls the drone's event loop.
"""

from __future__ import annotations

import asyncio
import base64
from collections import OrderedDict
from pathlib import Path
from typing import Any

from dronefleet.errors import NotFound
from dronefleet.messaging.gear import PHOTO_CHUNK_BYTES, PhotoChunk

KEPT = 10_000


class PhotoFiles:
    """``note(capture)`` after each picture; ``await chunk(name, offset)`` to serve one."""

    def __init__(self, drone_id: str, *, chunk_bytes: int = PHOTO_CHUNK_BYTES) -> None:
        self.drone_id = drone_id
        self.chunk_bytes = chunk_bytes
        self._files: OrderedDict[str, Path] = OrderedDict()

    def note(self, capture: dict[str, Any]) -> None:
        """Remember the file a capture record names (a camera without files names none)."""
        file = capture.get("file")
        if not isinstance(file, str) or not file:
            return
        path = Path(file)
        self._files[path.name] = path
        self._files.move_to_end(path.name)
        while len(self._files) > KEPT:
            self._files.popitem(last=False)

    async def chunk(self, name: str, offset: int) -> PhotoChunk:
        path = self._files.get(name)
        if path is None:
            raise NotFound(f"drone {self.drone_id} took no picture {name!r} since it started")
        size, data = await asyncio.to_thread(self._read, path, offset)
        return PhotoChunk(file=name, size_bytes=size, offset=offset, data=base64.b64encode(data))

    def _read(self, path: Path, offset: int) -> tuple[int, bytes]:
        try:
            with path.open("rb") as f:
                size = f.seek(0, 2)
                if offset > size:
                    raise NotFound(f"picture {path.name} has {size} bytes, not {offset}")
                f.seek(offset)
                return size, f.read(self.chunk_bytes)
        except FileNotFoundError:
            raise NotFound(f"picture {path.name} is no longer on drone {self.drone_id}") from None
