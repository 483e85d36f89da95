"""The simulated camera: each capture records where and when the picture was taken.

Implements :class:`~dronefleet.vehicle.payload.Camera` for the Gear Manager (the seed's aerial
photography experiment, section 5.2). With an output directory, each picture is written as a
small grey baseline JPEG carrying the position in its GPS EXIF tags, built with the standard
library only (a uniform image needs just one Huffman code per table).
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dronefleet.owner_only import open_private

if TYPE_CHECKING:
    from dronefleet.sim.vehicle import SimVehicle

#: Picture size in pixels (multiples of 8: whole JPEG blocks).
_WIDTH, _HEIGHT = 64, 48


class SimCamera:
    """Takes geotagged pictures from a simulated vehicle; indices count from 1."""

    def __init__(
        self, vehicle: SimVehicle, output_dir: str | Path | None = None, *, name: str = "camera"
    ) -> None:
        self.name = name
        self._vehicle = vehicle
        self._output_dir = Path(output_dir) if output_dir is not None else None
        self._count = 0

    @property
    def count(self) -> int:
        return self._count

    def capture(self) -> dict[str, Any]:
        vehicle = self._vehicle
        position = vehicle.position_lla
        self._count += 1
        info: dict[str, Any] = {
            "index": self._count,
            "lat": position.lat,
            "lon": position.lon,
            "alt_m": position.alt_m,
            "relative_alt_m": vehicle.relative_alt_m,
            "vehicle_time_s": vehicle.time_s,
        }
        if self._output_dir is not None:
            path = self._output_dir / f"{vehicle.vehicle_id}_{self._count:04d}.jpg"
            # The drone's pictures are its owner's only (issue 25): 0600, folders made 0700.
            with open_private(path) as out:
                out.write(geotagged_jpeg(position.lat, position.lon, position.alt_m))
            info["file"] = str(path)
        return info


# -- JPEG writing (stdlib only) ------------------------------------------------------------------


def geotagged_jpeg(lat: float, lon: float, alt_m: float) -> bytes:
    """A uniform grey baseline JPEG with GPS latitude, longitude and altitude in EXIF."""
    blocks = (_WIDTH // 8) * (_HEIGHT // 8)
    # Each block: DC difference category 0 (code "0") then end-of-block (code "0").
    bits = "00" * blocks
    bits += "1" * (-len(bits) % 8)
    scan = int(bits, 2).to_bytes(len(bits) // 8, "big")
    one_code = bytes([1] + [0] * 15)
    return b"".join(
        (
            b"\xff\xd8",
            _segment(0xE1, b"Exif\x00\x00" + _exif_gps(lat, lon, alt_m)),
            _segment(0xDB, b"\x00" + bytes([1] * 64)),
            _segment(0xC0, struct.pack(">BHHB3B", 8, _HEIGHT, _WIDTH, 1, 1, 0x11, 0)),
            _segment(0xC4, b"\x00" + one_code + b"\x00"),  # DC table 0: category 0
            _segment(0xC4, b"\x10" + one_code + b"\x00"),  # AC table 0: end of block
            _segment(0xDA, bytes([1, 1, 0x00, 0, 63, 0])),
            scan,
            b"\xff\xd9",
        )
    )


def _segment(marker: int, payload: bytes) -> bytes:
    return struct.pack(">BBH", 0xFF, marker, len(payload) + 2) + payload


def _dms(value: float) -> list[tuple[int, int]]:
    value = abs(value)
    degrees = int(value)
    minutes_f = (value - degrees) * 60.0
    minutes = int(minutes_f)
    seconds = round((minutes_f - minutes) * 60.0 * 10_000)
    return [(degrees, 1), (minutes, 1), (seconds, 10_000)]


def _exif_gps(lat: float, lon: float, alt_m: float) -> bytes:
    """A little-endian TIFF block: IFD0 pointing at a GPS IFD with lat, lon and altitude."""
    gps_ifd_offset = 8 + 2 + 12 + 4
    entries = 7
    data_offset = gps_ifd_offset + 2 + 12 * entries + 4
    lat_off, lon_off, alt_off = data_offset, data_offset + 24, data_offset + 48

    def entry(tag: int, kind: int, count: int, value: bytes) -> bytes:
        return struct.pack("<HHI", tag, kind, count) + value.ljust(4, b"\x00")

    byte, ascii_, long_, rational = 1, 2, 4, 5
    out = bytearray(b"II*\x00" + struct.pack("<I", 8))
    out += struct.pack("<H", 1) + entry(0x8825, long_, 1, struct.pack("<I", gps_ifd_offset))
    out += struct.pack("<I", 0)
    out += struct.pack("<H", entries)
    out += entry(0x0000, byte, 4, bytes([2, 3, 0, 0]))
    out += entry(0x0001, ascii_, 2, b"N\x00" if lat >= 0 else b"S\x00")
    out += entry(0x0002, rational, 3, struct.pack("<I", lat_off))
    out += entry(0x0003, ascii_, 2, b"E\x00" if lon >= 0 else b"W\x00")
    out += entry(0x0004, rational, 3, struct.pack("<I", lon_off))
    out += entry(0x0005, byte, 1, bytes([0 if alt_m >= 0 else 1]))
    out += entry(0x0006, rational, 1, struct.pack("<I", alt_off))
    out += struct.pack("<I", 0)
    for rationals in (_dms(lat), _dms(lon), [(round(abs(alt_m) * 100), 100)]):
        for num, den in rationals:
            out += struct.pack("<II", num, den)
    return bytes(out)
