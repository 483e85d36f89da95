"""Thumbnails and the zip of a mission's pictures: the image work, done on worker threads.

Pillow makes the thumbnails: it is the kept Python imaging library (decoders for every JPEG a
camera writes, ``draft`` mode that decodes a 20-megapixel JPEG at 1/8 scale in a few
milliseconds), pinned in constraints.txt. The pictures themselves are never re-encoded: what a
drone took is kept and served byte for byte, so its EXIF (GPS position, camera, time) stays as
the camera wrote it, which photogrammetry tools (OpenDroneMap) read.
"""

from __future__ import annotations

import io
import os
import zipfile
from pathlib import Path

from PIL import Image, ImageOps, UnidentifiedImageError

from dronefleet.errors import InvalidInput
from dronefleet.owner_only import open_private

THUMB_PX = 256  # the longer side of a thumbnail
THUMB_QUALITY = 80


class NotAPicture(InvalidInput):
    """Bytes a drone sent as a picture that no image decoder reads."""


def thumbnail(data: bytes) -> bytes:
    """A JPEG at most :data:`THUMB_PX` on its longer side, turned upright by its EXIF."""
    try:
        with Image.open(io.BytesIO(data)) as image:
            image.draft("RGB", (THUMB_PX, THUMB_PX))  # JPEG: decode at a reduced scale
            small = ImageOps.exif_transpose(image).convert("RGB")
            small.thumbnail((THUMB_PX, THUMB_PX))
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise NotAPicture(f"not a picture: {exc}") from None
    out = io.BytesIO()
    small.save(out, "JPEG", quality=THUMB_QUALITY)
    return out.getvalue()


def write_zip(files: list[tuple[str, Path]], dest: Path) -> None:
    """``dest``: a zip of ``files`` (name in the zip, path), stored as they are (JPEG does not
    compress), written beside and renamed into place so a reader never sees half of one."""
    part = dest.with_suffix(".part")
    with (
        open_private(part) as out,
        zipfile.ZipFile(out, "w", compression=zipfile.ZIP_STORED) as archive,
    ):
        for name, path in files:
            archive.write(path, name)
    os.replace(part, dest)
