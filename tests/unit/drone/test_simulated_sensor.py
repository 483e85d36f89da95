"""The companion computer's simulated gas sensor (issue 28, item 6): it reads the field where the
autopilot says the vehicle is, at its height above home, and every reading says it is simulated."""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import pytest

from dronefleet.cli.args import given_options, note_given
from dronefleet.cli.drone import simulated_co2
from dronefleet.drone.gear import GearManager
from dronefleet.drone.simulated_sensor import SimulatedSensor
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.sim.gasfield import BACKGROUND_CO2_PPM
from dronefleet.vehicle.payload import Sensor

HOME = LLA(-35.363262, 149.165237, 584.0)  # ArduPilot SITL's field: 584 m above the sea


@dataclass
class _Clock:
    t: float = 12.5

    def now(self) -> float:
        return self.t


class _Autopilot:
    """As much of a FlightController as the sensor uses."""

    def __init__(self) -> None:
        self.clock = _Clock()
        self.here = HOME

    def position(self) -> LLA:
        return self.here

    def home(self) -> LLA:
        return HOME


def test_reads_the_plume_where_the_autopilot_is_at_its_height_above_home():
    fc = _Autopilot()
    plume = ned_to_lla(NED(40, 0), HOME)
    sensor = simulated_co2(fc, [(plume.lat, plume.lon, 3000.0, 12.0)])  # type: ignore[arg-type]
    assert isinstance(sensor, Sensor)
    on_the_ground = sensor.read()
    assert on_the_ground.value == pytest.approx(BACKGROUND_CO2_PPM, abs=15)
    fc.here = ned_to_lla(NED(40, 0, -10), HOME)  # 10 m over the plume's centre, 594 m AMSL
    over = sensor.read()
    assert over.value == pytest.approx(BACKGROUND_CO2_PPM + 3000 * 0.7066, rel=1e-3)
    assert (over.sensor, over.unit, over.vehicle_time_s) == ("CO2", "ppm", 12.5)
    assert over.extra["simulated"] is True and over.extra["source"] == "--plume"
    assert over.extra["alt_m"] == pytest.approx(594.0)  # where it was read, as the autopilot says


def test_the_gear_streams_it_as_co2_ppm_where_it_was_read():
    fc = _Autopilot()
    sensor = SimulatedSensor(fc, lambda at: 400.0 + at.alt_m)  # type: ignore[arg-type]
    fc.here = LLA(HOME.lat, HOME.lon, HOME.alt_m + 20)
    gear = GearManager("QUAD_1", None, fc.clock, gear_dir=None, sensors={"CO2": sensor})  # type: ignore[arg-type]
    assert gear.sample() == {"co2_ppm": 420.0, "lat": HOME.lat, "lon": HOME.lon, "alt_m": 604.0}


def test_note_given_names_the_options_typed_even_with_their_default():
    p = argparse.ArgumentParser()
    p.add_argument("--speedup", type=float, default=1.0)
    p.add_argument("--plume", action="append", default=[])
    p.add_argument("--fail", action=argparse.BooleanOptionalAction, default=True)
    p.add_argument("--quiet", action="store_true")
    note_given(p)
    note_given(p)  # twice is harmless
    args = p.parse_args(["--plume", "a", "--speedup", "1", "--no-fail", "--plume", "b"])
    assert given_options(args) == {"speedup": "--speedup", "fail": "--no-fail", "plume": "--plume"}
    assert (args.speedup, args.plume, args.fail, args.quiet) == (1.0, ["a", "b"], False, False)
    assert given_options(p.parse_args([])) == {}
