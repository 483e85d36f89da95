"""The vehicle the estimator flies: its limits, currents, way home and wind (:class:`VehicleModel`),
read from what a drone reports of its vehicle (:meth:`VehicleModel.of_vehicle`) and put in the
wind the estimate flies in (:func:`vehicle_model`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from dronefleet.vehicle.kinematics import FlightLimits


@dataclass(frozen=True)
class VehicleModel:
    """The limits and currents of a vehicle (defaults: the simulated quad of docs/DESIGN.md §5)."""

    max_speed_mps: float = 10.0
    max_climb_mps: float = 2.0
    max_descent_mps: float = 1.5
    accel_mps2: float = 2.5
    accel_z_mps2: float = 2.5
    arming_s: float = 3.0
    capacity_mah: float = 5500.0
    hover_current_a: float = 18.0
    idle_current_a: float = 0.5
    armed_idle_current_a: float = 3.0
    horizontal_tolerance_m: float = 2.0
    vertical_tolerance_m: float = 2.0
    takeoff_altitude_m: float = 10.0
    picture_s: float = 0.1  # a picture taken while stopped (gear round trip)
    poll_s: float = 0.05  # the Mission Worker's wait_for_flight polling
    # ArduPilot lands in two stages: down to LAND_ALT_LOW at LAND_SPEED_HIGH (0: WPNAV_SPEED_DN,
    # the descent above), then LAND_SPEED (ArduCopter Mode::get_land_descent_speed; parameters:
    # LAND_SPEED 50 cm/s, LAND_SPEED_HIGH 0, LAND_ALT_LOW 1000 cm by default, ardupilot.org
    # Copter parameter list; LAND_SPD_MS, LAND_SPD_HIGH_MS, LAND_ALT_LOW_M on 4.7).
    land_speed_mps: float | None = None
    land_alt_low_m: float = 0.0
    land_speed_high_mps: float | None = None
    #: Seconds on the ground before the vehicle says it has landed: ArduPilot's land detector
    #: (LAND_DETECTOR_TRIGGER_SEC, 1 s) decides, then disarms; our simulator's at touchdown.
    land_detect_s: float = 0.0
    #: The mean current this vehicle was measured to draw in the air (drone/draw.py). When known
    #: it replaces the hover/forward/climb model, which is the dissertation quad's, not this one's.
    flight_current_a: float | None = None
    # -- the way home (``rtl``) ------------------------------------------------------------------
    #: The autopilot flies RTL itself (ArduPilot's ModeRTL, over MAVLink); else the companion
    #: computer does (drone/navigation.py: home at max(height, RTL_ALT_M) climbing on the way,
    #: landing once within the horizontal tolerance).
    native_rtl: bool = False
    #: RTL_ALT (1500 cm; RTL_ALT_M on 4.7): the least height it flies home at; higher stays higher.
    rtl_alt_m: float = 15.0
    #: RTL_SPEED (0 cm/s: WPNAV_SPEED; RTL_SPEED_MS on 4.7): None flies home at max_speed_mps.
    rtl_speed_mps: float | None = None
    #: RTL_ALT_FINAL (0: land; RTL_ALT_FINAL_M on 4.7): above 0 it stops there, in the air.
    rtl_alt_final_m: float = 0.0
    #: RTL_LOIT_TIME (5000 ms): the hover over home before the descent (a native RTL's only).
    #: ArduPilot also turns back to the heading it armed with there, within the same seconds.
    rtl_loiter_s: float = 5.0
    #: RTL_CONE_SLOPE (3): near home the climb is limited to distance * slope (0: no cone).
    rtl_cone_slope: float = 3.0
    #: RTL_CLIMB_MIN (0 cm): the least climb before returning.
    rtl_climb_min_m: float = 0.0
    #: The least time an autopilot's waypoint stage takes even when it has nowhere to go: its
    #: S-curve ramps the acceleration at WP_JERK, so WP_ACC / WP_JERK (2.5 s by default). On
    #: ArduPilot Copter SITL an RTL from a hover at its return height moved off after 2.4 s.
    wp_settle_s: float = 0.0
    # -- wind ------------------------------------------------------------------------------------
    #: Air velocity over the ground (towards north, east), m/s: the operator's ``wind_mps`` and
    #: ``wind_from_deg``, else the autopilot's estimate, else calm (the preview says so).
    wind_n_mps: float = 0.0
    wind_e_mps: float = 0.0
    #: The airspeed the vehicle cannot exceed: flying into wind above it, it makes less ground.
    #: None: max_speed_mps (our simulator: sim/wind.py). An ArduPilot Copter holds WPNAV_SPEED
    #: over the ground up to its lean limit: ArduPilot Copter SITL (upstream 64a9c78, "+" frame,
    #: default angles) made 6.5 m/s against 6 m/s of wind at WP_SPD 10, so 12.5 m/s of air.
    max_airspeed_mps: float | None = None

    @classmethod
    def of_vehicle(cls, params: dict[str, Any] | None, base: VehicleModel | None = None) -> Any:
        """This model with what a drone reported of its vehicle (``Heartbeat.flight``): its
        autopilot's speeds, accelerations, landing and capacity, and its measured flight draw.

        ArduPilot limits jerk too (WP_JERK): reaching speed v then takes v/a + a/j, not v/a. The
        trapezoids here use the acceleration that takes that long, which covers the same
        distance as the S-curve (both average v/2 while speeding up).

        A vehicle that reports its autopilot's landing speed (LAND_SPEED: the MAVLink backend,
        drone/fc/mavlink/flight_params.py) lands and returns home by itself: ArduPilot's RTL, land
        detector and airspeed limit. The RTL figures (``rtl_alt_m``, ``rtl_speed_mps``,
        ``rtl_alt_final_m``, ``rtl_loiter_s``, ``land_speed_high_mps``) are read when the drone
        reports them; until then ArduPilot's defaults stand."""
        model = base or cls()
        if not params:
            return model
        value = {k: float(v) for k, v in params.items() if isinstance(v, int | float) and v > 0}
        if "land_speed_mps" in value:
            model = replace(
                model, native_rtl=True, land_detect_s=_LAND_DETECTOR_S,
                max_airspeed_mps=model.max_airspeed_mps or _ARDUPILOT_AIRSPEED_MPS,
                wp_settle_s=model.wp_settle_s or _ARDUPILOT_SETTLE_S,
            )  # fmt: skip
        mapping = {
            "speed_mps": "max_speed_mps",
            "accel_mps2": "accel_mps2",
            "accel_z_mps2": "accel_z_mps2",
            "climb_mps": "max_climb_mps",
            "descent_mps": "max_descent_mps",
            "land_speed_mps": "land_speed_mps",
            "land_alt_low_m": "land_alt_low_m",
            "capacity_mah": "capacity_mah",
            "hover_current_a": "hover_current_a",
            "flight_current_a": "flight_current_a",
            "land_speed_high_mps": "land_speed_high_mps",
            "rtl_alt_m": "rtl_alt_m",
            "rtl_speed_mps": "rtl_speed_mps",
            "rtl_loiter_s": "rtl_loiter_s",
        }
        changes: dict[str, Any] = {
            ours: value[theirs] for theirs, ours in mapping.items() if theirs in value
        }
        zero_ok = ("rtl_alt_final_m", "rtl_loiter_s", "rtl_cone_slope", "rtl_climb_min_m")
        for key in zero_ok:  # zero is a setting here, not "unknown"
            raw = params.get(key)
            if isinstance(raw, int | float) and raw >= 0:
                changes[key] = float(raw)
        if "accel_mps2" in changes and "accel_z_mps2" not in changes:
            changes["accel_z_mps2"] = changes["accel_mps2"]
        jerk = value.get("jerk_mps3")
        if jerk:
            changes["wp_settle_s"] = changes.get("accel_mps2", model.accel_mps2) / jerk
            speed = changes.get("max_speed_mps", model.max_speed_mps)
            climb = changes.get("max_climb_mps", model.max_climb_mps)
            a = changes.get("accel_mps2", model.accel_mps2)
            az = changes.get("accel_z_mps2", model.accel_z_mps2)
            changes["accel_mps2"] = speed / (speed / a + a / jerk)
            changes["accel_z_mps2"] = climb / (climb / az + az / jerk)
        return replace(model, **changes)

    @property
    def limits(self) -> FlightLimits:
        return FlightLimits(
            self.max_speed_mps,
            self.max_climb_mps,
            self.max_descent_mps,
            self.accel_mps2,
            self.accel_z_mps2,
        )

    def with_wind(self, speed_mps: float, from_deg: float) -> VehicleModel:
        """This model in a steady wind of ``speed_mps`` blowing from ``from_deg`` (0 = north)."""
        to = math.radians(from_deg + 180.0)
        return replace(
            self, wind_n_mps=speed_mps * math.cos(to), wind_e_mps=speed_mps * math.sin(to)
        )

    @property
    def wind_mps(self) -> float:
        return math.hypot(self.wind_n_mps, self.wind_e_mps)

    @property
    def airspeed_cap_mps(self) -> float:
        return self.max_airspeed_mps or self.max_speed_mps


DEFAULT_MODEL = VehicleModel()
#: ArduPilot's land detector: LAND_DETECTOR_TRIGGER_SEC (ArduCopter/land_detector.cpp), 1 s.
_LAND_DETECTOR_S = 1.0
#: The airspeed an ArduPilot Copter reaches at its lean limit, measured on SITL (see above).
_ARDUPILOT_AIRSPEED_MPS = 12.5
#: WP_ACC / WP_JERK at ArduPilot's defaults (250 cm/s², 1 m/s³).
_ARDUPILOT_SETTLE_S = 2.5


def vehicle_model(
    flight: dict[str, Any] | None,
    *,
    reported_wind: dict[str, Any] | None = None,
    wind_mps: float | None = None,
    wind_from_deg: float = 0.0,
) -> tuple[VehicleModel, str]:
    """A drone's model (its ``Heartbeat.flight``) in the wind the estimate flies in, and a note
    saying which: the operator's (``wind_mps`` from ``wind_from_deg``), else the autopilot's
    estimate (``Heartbeat.wind``), else none."""
    model = VehicleModel.of_vehicle(flight)
    if wind_mps is not None:
        note = f"wind {wind_mps:g} m/s from {wind_from_deg:.0f}° (given with the mission)"
        return model.with_wind(wind_mps, wind_from_deg), note
    speed = (reported_wind or {}).get("speed_mps")
    if isinstance(speed, int | float):
        origin = float((reported_wind or {}).get("from_deg") or 0.0)
        note = f"wind {speed:.1f} m/s from {origin:.0f}° (its autopilot's estimate)"
        if speed < 0.05:
            note = "no wind (its autopilot's estimate)"
        return model.with_wind(float(speed), origin), note
    return model, "no wind assumed (none given with the mission, none reported by the drone)"
