"""What the Gear Manager reads: a CO2 sensor over a gas field, and a geotagging camera."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.sim import GasField, GasSensor, Plume, SimCamera
from dronefleet.vehicle.payload import Camera, Sensor


def test_the_gas_field_peaks_at_a_plume_centre(home: LLA) -> None:
    centre = ned_to_lla(NED(40, 30, 0), home)
    field = GasField([Plume(centre, peak_ppm=2000.0, radius_m=10.0)])
    assert field.concentration_ppm(centre) == pytest.approx(2420.0)
    one_sigma = ned_to_lla(NED(50, 30, 0), home)
    assert field.concentration_ppm(one_sigma) == pytest.approx(420 + 2000 * 0.6065, rel=1e-3)
    far = ned_to_lla(NED(-200, 0, 0), home)
    assert field.concentration_ppm(far) == pytest.approx(420.0)


def test_the_co2_sensor_reads_more_over_the_plume(hovering, fly) -> None:
    centre = ned_to_lla(NED(40, 0, -10), hovering.home)
    sensor = GasSensor(hovering, GasField([Plume(centre, 1500.0, 8.0)]))
    assert isinstance(sensor, Sensor)
    assert (sensor.name, sensor.unit) == ("CO2", "ppm")
    before = sensor.read()
    hovering.goto(NED(40, 0, -10))
    fly(hovering, until=lambda: hovering.position_ned == NED(40, 0, -10))
    over = sensor.read()
    assert before.value == pytest.approx(420.0, abs=1)
    assert over.value == pytest.approx(1920.0, abs=1)
    assert over.vehicle_time_s == hovering.time_s
    assert over.extra["lat"] == pytest.approx(centre.lat)


def test_the_camera_records_where_and_when(hovering, tmp_path) -> None:
    camera = SimCamera(hovering, tmp_path / "pictures")
    assert isinstance(camera, Camera)
    first, second = camera.capture(), camera.capture()
    assert (first["index"], second["index"]) == (1, 2)
    assert first["relative_alt_m"] == pytest.approx(10.0)
    assert first["alt_m"] == pytest.approx(hovering.home.alt_m + 10.0)
    assert first["vehicle_time_s"] == hovering.time_s
    assert first["lat"] == pytest.approx(hovering.home.lat)
    data = Path(first["file"]).read_bytes()
    assert data[:2] == b"\xff\xd8" and data[-2:] == b"\xff\xd9"
    assert _exif_latitude(data) == pytest.approx(hovering.home.lat, abs=1e-6)


def test_the_camera_without_a_directory_writes_nothing(hovering) -> None:
    assert "file" not in SimCamera(hovering).capture()


def _exif_latitude(jpeg: bytes) -> float:
    """GPSLatitude from the APP1 segment (little-endian TIFF as written by the camera)."""
    assert jpeg[2:4] == b"\xff\xe1" and jpeg[6:12] == b"Exif\x00\x00"
    tiff = jpeg[12:]
    gps_ifd = struct.unpack_from("<I", tiff, 8 + 2 + 8)[0]
    count = struct.unpack_from("<H", tiff, gps_ifd)[0]
    for i in range(count):
        tag, _, _, offset = struct.unpack_from("<HHII", tiff, gps_ifd + 2 + 12 * i)
        if tag == 0x0002:
            d, dd, m, md, s, sd = struct.unpack_from("<6I", tiff, offset)
            return d / dd + m / md / 60 + s / sd / 3600
    raise AssertionError("no GPSLatitude tag")
