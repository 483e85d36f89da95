"""What the ground stores of a telemetry message (messaging/telemetry_schema.py): known fields
with possible values; the rest is counted and left out, the message itself never changed."""

from __future__ import annotations

import math

from dronefleet.messaging.telemetry_schema import screen

SAMPLE = {"lat": 40.63, "lon": -8.66, "alt_m": 31.0, "battery_pct": 76.5, "in_air": 1.0}


def test_a_flight_sample_is_kept_whole() -> None:
    fields = dict(SAMPLE)
    assert screen(fields) == (SAMPLE, 0, 0)


def test_unknown_and_impossible_fields_are_counted_and_left_out_of_a_copy() -> None:
    for bad, counts in (
        ({"lat": 95.0}, (0, 1)),
        ({"battery_pct": math.nan}, (0, 1)),
        ({"alt_m": math.inf}, (0, 1)),
        ({"Lat": 40.0}, (1, 0)),
        ({"co2_ppm": -1.0}, (0, 1)),
    ):
        fields = {**SAMPLE, **bad}
        before = dict(fields)
        kept, unknown, out_of_range = screen(fields)
        expected = {k: v for k, v in SAMPLE.items() if k not in bad}
        assert (kept, unknown, out_of_range) == (expected, *counts), bad
        assert fields.keys() == before.keys()  # the message's own map is left as it came


def test_a_sensor_reading_in_its_units_range_is_kept() -> None:
    kept, unknown, out_of_range = screen({**SAMPLE, "co2_ppm": 415.0, "temp_c": 21.5})
    assert kept == {**SAMPLE, "co2_ppm": 415.0, "temp_c": 21.5}
    assert (unknown, out_of_range) == (0, 0)
