"""Multirotor point-mass kinematics: what the autopilot's position controller makes the frame do.

The vehicle flies towards a position target with an acceleration-limited trapezoidal speed
profile, horizontal and vertical separately (as ArduPilot's WPNAV does): it accelerates at
``accel_mps2``, cruises at the speed limit and brakes so that it stops on the target. The
horizontal profile runs along the straight line to the target, so a goto from hover is a straight
line. Limits default to the seed's: 10 m/s horizontal, 2 m/s climb (section 5.1), 2.5 m/s²
(docs/DESIGN.md §10). Everything here is in local NED metres of the vehicle's home; the ground is
the plane D = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

GRAVITY_MPS2 = 9.80665
#: Terminal speed of a falling, unpowered quadcopter (motors off).
_TERMINAL_FALL_MPS = 20.0
#: How fast a falling frame's horizontal velocity relaxes towards the wind (1/s).
_FALL_DRAG_PER_S = 0.5
#: Closer than this to the target, with a speed one braking step can remove, the vehicle is there.
_ARRIVED_M = 0.01


@dataclass(frozen=True, slots=True)
class FlightLimits:
    """Speed and acceleration limits of the position controller."""

    max_speed_mps: float = 10.0  # horizontal, ground and air
    max_climb_mps: float = 2.0
    max_descent_mps: float = 1.5
    accel_mps2: float = 2.5  # horizontal
    accel_z_mps2: float = 2.5  # vertical

    def __post_init__(self) -> None:
        for name in ("max_speed_mps", "max_climb_mps", "max_descent_mps", "accel_mps2"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive")
        if not self.accel_z_mps2 > 0:
            raise ValueError("accel_z_mps2 must be positive")


def stopping_speed(distance_m: float, accel_mps2: float, dt_s: float) -> float:
    """Highest speed from which braking at ``accel_mps2`` in steps of ``dt_s`` stops within
    ``distance_m`` (the discrete form of sqrt(2·a·d), so the profile lands on the target)."""
    half = 0.5 * accel_mps2 * dt_s
    return -half + math.sqrt(half * half + 2.0 * accel_mps2 * distance_m)


def limit_airspeed(
    vn: float, ve: float, wind_n: float, wind_e: float, max_airspeed: float
) -> tuple[float, float]:
    """Scale a wanted ground velocity down until the airspeed it needs is within the limit.

    Upwind the vehicle is slower over the ground; if the wind is stronger than the vehicle can
    fly, it points into the wind at full airspeed and drifts.
    """
    an, ae = vn - wind_n, ve - wind_e
    if an * an + ae * ae <= max_airspeed * max_airspeed:
        return vn, ve
    ww = wind_n * wind_n + wind_e * wind_e
    vv = vn * vn + ve * ve
    if ww >= max_airspeed * max_airspeed or vv == 0.0:
        w = math.sqrt(ww)
        k = max(0.0, 1.0 - max_airspeed / w) if w > 0 else 0.0
        return wind_n * k, wind_e * k
    vw = vn * wind_n + ve * wind_e
    k = (vw + math.sqrt(vw * vw - vv * (ww - max_airspeed * max_airspeed))) / vv
    k = min(1.0, max(0.0, k))
    return vn * k, ve * k


class Kinematics:
    """Position, velocity and last acceleration of one vehicle in home NED."""

    __slots__ = ("ad", "ae", "an", "d", "e", "n", "vd", "ve", "vn")

    def __init__(self, n: float = 0.0, e: float = 0.0, d: float = 0.0) -> None:
        self.n, self.e, self.d = n, e, d
        self.vn = self.ve = self.vd = 0.0
        self.an = self.ae = self.ad = 0.0

    @property
    def on_ground(self) -> bool:
        return self.d >= -1e-3

    def stop_point(self, limits: FlightLimits) -> tuple[float, float, float]:
        """Where the vehicle comes to rest if it starts braking now (the HOLD target)."""
        k_h = 1.0 / (2.0 * limits.accel_mps2)
        k_v = 1.0 / (2.0 * limits.accel_z_mps2)
        speed = math.hypot(self.vn, self.ve)
        return (
            self.n + self.vn * speed * k_h,
            self.e + self.ve * speed * k_h,
            min(0.0, self.d + self.vd * abs(self.vd) * k_v),
        )

    def fly_to(
        self,
        target_n: float,
        target_e: float,
        target_d: float,
        dt_s: float,
        limits: FlightLimits,
        wind_n: float = 0.0,
        wind_e: float = 0.0,
        max_descent_mps: float | None = None,
    ) -> None:
        """One position-controller step towards the target."""
        self._horizontal(target_n, target_e, dt_s, limits, wind_n, wind_e)
        descent = limits.max_descent_mps if max_descent_mps is None else max_descent_mps
        self._vertical(target_d, dt_s, limits, descent)

    def fly_velocity(
        self,
        want: tuple[float, float, float],
        dt_s: float,
        limits: FlightLimits,
        wind_n: float = 0.0,
        wind_e: float = 0.0,
    ) -> None:
        """One velocity-controller step towards ``want`` (north, east, down m/s), within the
        acceleration and speed limits (a GUIDED velocity target)."""
        vn, ve = limit_airspeed(want[0], want[1], wind_n, wind_e, limits.max_speed_mps)
        a_step = limits.accel_mps2 * dt_s
        dvn, dve = vn - self.vn, ve - self.ve
        dv = math.hypot(dvn, dve)
        if dv > a_step:
            dvn, dve = dvn * a_step / dv, dve * a_step / dv
        self.vn, self.ve = self.vn + dvn, self.ve + dve
        self.an, self.ae = dvn / dt_s, dve / dt_s
        self.n += self.vn * dt_s
        self.e += self.ve * dt_s
        vd = max(-limits.max_climb_mps, min(limits.max_descent_mps, want[2]))
        dvd = max(-limits.accel_z_mps2 * dt_s, min(limits.accel_z_mps2 * dt_s, vd - self.vd))
        self.vd += dvd
        self.ad = dvd / dt_s
        self.d += self.vd * dt_s
        if self.d > 0.0:  # the ground stops it
            self.d, self.vd, self.ad = 0.0, 0.0, 0.0

    def _horizontal(
        self, tn: float, te: float, dt: float, lim: FlightLimits, wind_n: float, wind_e: float
    ) -> None:
        en, ee = tn - self.n, te - self.e
        dist = math.hypot(en, ee)
        a_step = lim.accel_mps2 * dt
        if dist < _ARRIVED_M and math.hypot(self.vn, self.ve) <= a_step:
            self.an, self.ae = -self.vn / dt, -self.ve / dt
            self.n, self.e, self.vn, self.ve = tn, te, 0.0, 0.0
            return
        if dist > 0.0:
            speed = min(lim.max_speed_mps, stopping_speed(dist, lim.accel_mps2, dt), dist / dt)
            want_n, want_e = en / dist * speed, ee / dist * speed
        else:
            want_n = want_e = 0.0
        want_n, want_e = limit_airspeed(want_n, want_e, wind_n, wind_e, lim.max_speed_mps)
        dvn, dve = want_n - self.vn, want_e - self.ve
        dv = math.hypot(dvn, dve)
        if dv > a_step:
            dvn, dve = dvn * a_step / dv, dve * a_step / dv
        self.vn += dvn
        self.ve += dve
        self.an, self.ae = dvn / dt, dve / dt
        self.n += self.vn * dt
        self.e += self.ve * dt

    def _vertical(self, td: float, dt: float, lim: FlightLimits, max_descent: float) -> None:
        err = td - self.d  # > 0: go down
        a_step = lim.accel_z_mps2 * dt
        if abs(err) < _ARRIVED_M and abs(self.vd) <= a_step:
            self.ad = -self.vd / dt
            self.d, self.vd = td, 0.0
            return
        cap = max_descent if err > 0 else lim.max_climb_mps
        speed = min(cap, stopping_speed(abs(err), lim.accel_z_mps2, dt), abs(err) / dt)
        want = math.copysign(speed, err)
        dv = max(-a_step, min(a_step, want - self.vd))
        self.vd += dv
        self.ad = dv / dt
        self.d += self.vd * dt
        if self.d > 0.0:  # the ground stops it
            self.d, self.vd, self.ad = 0.0, 0.0, 0.0

    def fall(self, dt_s: float, wind_n: float = 0.0, wind_e: float = 0.0) -> None:
        """Motors off: gravity with drag; lands (hard) on the ground plane."""
        drag = GRAVITY_MPS2 / (_TERMINAL_FALL_MPS * _TERMINAL_FALL_MPS)
        self.ad = GRAVITY_MPS2 - drag * self.vd * abs(self.vd)
        relax = min(1.0, _FALL_DRAG_PER_S * dt_s)
        self.an = (wind_n - self.vn) * relax / dt_s
        self.ae = (wind_e - self.ve) * relax / dt_s
        self.vn += self.an * dt_s
        self.ve += self.ae * dt_s
        self.vd += self.ad * dt_s
        self.n += self.vn * dt_s
        self.e += self.ve * dt_s
        self.d += self.vd * dt_s
        if self.d >= 0.0:
            self.rest_on_ground()

    def rest_on_ground(self) -> None:
        self.d = 0.0
        self.vn = self.ve = self.vd = 0.0
        self.an = self.ae = self.ad = 0.0
