"""How long a drone takes to fly a list of mission steps, and how much battery it uses.

The Mission Planner (seed 4.2.4) refuses missions a battery cannot finish and shares work by time,
so it needs the flight time of steps before they are flown. This module replays the steps with the
vehicle model the simulator flies too (:mod:`dronefleet.vehicle.kinematics`,
:mod:`dronefleet.vehicle.battery`): trapezoidal legs (2.5 m/s², 10 m/s; climb 2 m/s, descent 1.5
m/s), horizontal and vertical at once; ``wait_for_flight`` ends inside the tolerance cylinder
(Algorithm 1, 2 m) on the Mission Worker's 0.1 s polling, so the next leg starts with the speed
carried from this one. Straight legs are solved in closed form; when a leg turns (speed across the
new direction) the few seconds of the turn are stepped with the simulator's own position
controller. Current: hover, plus forward flight and climb, as the sim's battery model draws it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.estimate_units import Keys, Replay, Units, fly_unit
from dronefleet.vehicle.battery import Battery
from dronefleet.vehicle.kinematics import FlightLimits, Kinematics

_TURN_MPS = 0.25  # speed across the leg above which the turn is stepped, not solved
_TURN_DT_S = 0.05  # the sim world's step
_B = Battery()
_FORWARD = _B.flight_current_a(1.0, 0.0, 1.0) / _B.hover_current_a - 1.0
_CLIMB = _B.flight_current_a(0.0, 1.0, 1.0) / _B.hover_current_a - 1.0
_DESCENT = 1.0 - _B.flight_current_a(0.0, -1.0, 1.0) / _B.hover_current_a


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
    # ArduPilot lands in two stages: down to LAND_ALT_LOW at WPNAV_SPEED_DN, then LAND_SPEED.
    land_speed_mps: float | None = None
    land_alt_low_m: float = 0.0
    #: The mean current this vehicle was measured to draw in the air (drone/draw.py). When known
    #: it replaces the hover/forward/climb model, which is the dissertation quad's, not this one's.
    flight_current_a: float | None = None

    @classmethod
    def of_vehicle(cls, params: dict[str, Any] | None, base: VehicleModel | None = None) -> Any:
        """This model with what a drone reported of its vehicle (``Heartbeat.flight``): its
        autopilot's speeds, accelerations, landing and capacity, and its measured flight draw.

        ArduPilot limits jerk too (WP_JERK): reaching speed v then takes v/a + a/j, not v/a. The
        trapezoids here use the acceleration that takes that long, which covers the same
        distance as the S-curve (both average v/2 while speeding up)."""
        model = base or cls()
        if not params:
            return model
        value = {k: float(v) for k, v in params.items() if isinstance(v, int | float) and v > 0}
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
        }
        changes = {ours: value[theirs] for theirs, ours in mapping.items() if theirs in value}
        if "accel_mps2" in changes and "accel_z_mps2" not in changes:
            changes["accel_z_mps2"] = changes["accel_mps2"]
        jerk = value.get("jerk_mps3")
        if jerk:
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


DEFAULT_MODEL = VehicleModel()


class Profile:
    """1-D trapezoidal motion from speed ``s`` towards a target ``d`` metres ahead, then rest."""

    __slots__ = ("d", "phases")

    def __init__(self, d: float, s: float, vmax: float, a: float) -> None:
        self.d = d
        self.phases: list[tuple[float, float, float, float]] = []  # (dur, x0, v0, acc)
        x = 0.0
        if s < 0 or s * s > 2 * a * d + 1e-9:  # moving away, or too fast to stop: brake first
            dur = abs(s) / a
            self._add(dur, x, s, -math.copysign(a, s))
            x += s * dur / 2
            s = 0.0
        rest = d - x
        sign = 1.0 if rest >= 0 else -1.0
        dist = abs(rest)
        peak = min(vmax, math.sqrt(a * dist + s * s / 2))
        peak = max(peak, s)
        d1, d3 = (peak * peak - s * s) / (2 * a), peak * peak / (2 * a)
        t1, t3 = (peak - s) / a, peak / a
        t2 = max(0.0, dist - d1 - d3) / peak if peak > 0 else 0.0
        self._add(t1, x, sign * s, sign * a)
        x += sign * d1
        self._add(t2, x, sign * peak, 0.0)
        x += sign * peak * t2
        self._add(t3, x, sign * peak, -sign * a)

    def _add(self, dur: float, x0: float, v0: float, acc: float) -> None:
        if dur > 0:
            self.phases.append((dur, x0, v0, acc))

    def at(self, t: float) -> tuple[float, float, float]:
        """Position, speed and the integral of speed² over [0, t]."""
        v2 = 0.0
        for dur, x0, v0, acc in self.phases:
            tau = min(t, dur)
            v2 += v0 * v0 * tau + v0 * acc * tau * tau + acc * acc * tau**3 / 3
            if t <= dur:
                return x0 + v0 * tau + acc * tau * tau / 2, v0 + acc * tau, v2
            t -= dur
        return self.d, 0.0, v2

    def time_within(self, tol: float) -> float:
        """First time the distance to the target is below ``tol``."""
        if abs(self.d) < tol:
            return 0.0
        elapsed = 0.0
        for dur, x0, v0, acc in self.phases:
            taus = [_root(x0 - goal, v0, acc / 2, dur) for goal in (self.d - tol, self.d + tol)]
            hits = [tau for tau in taus if tau is not None]
            if hits:
                return elapsed + min(hits)
            elapsed += dur
        return elapsed

    @property
    def duration(self) -> float:
        return sum(p[0] for p in self.phases)


def _root(c: float, b: float, a: float, limit: float) -> float | None:
    """Smallest root in [0, limit] of a·t² + b·t + c (sign change from c)."""
    if abs(a) < 1e-12:
        if abs(b) < 1e-12:
            return None
        t = -c / b
    else:
        disc = b * b - 4 * a * c
        if disc < 0:
            return None
        roots = sorted(((-b - math.sqrt(disc)) / (2 * a), (-b + math.sqrt(disc)) / (2 * a)))
        t = next((r for r in roots if r >= -1e-12), -1.0)
    return max(0.0, t) if -1e-12 <= t <= limit + 1e-12 else None


def rest_to_within_s(distance_m: float, tol_m: float, vmax: float, accel: float) -> float:
    """Time of a leg from rest until within ``tol_m`` of a target ``distance_m`` away."""
    return Profile(distance_m, 0.0, vmax, accel).time_within(tol_m)


@dataclass
class _State:
    model: VehicleModel
    n: float = 0.0
    e: float = 0.0
    vn: float = 0.0
    ve: float = 0.0
    h: float = 0.0  # height above home
    vz: float = 0.0  # up
    target: tuple[float, float] | None = None
    target_h: float | None = None
    armed: bool = False
    in_air: bool = False
    landing: bool = False
    land_extra_s: float = 0.0  # the slow last stage of a landing, beyond the profile
    charge_as: float = 0.0  # ampere-seconds drawn
    notes: list[str] = field(default_factory=list)

    # -- horizontal ---------------------------------------------------------------------------
    def _horizontal(self, duration: float, tol: float | None = None) -> tuple[float, float]:
        """Fly for ``duration`` s or until within ``tol``; returns (time, ∫speed² dt)."""
        m, t, v2 = self.model, 0.0, 0.0
        while self.target is not None and duration - t > 1e-12:
            tn, te = self.target
            dn, de = tn - self.n, te - self.e
            dist = math.hypot(dn, de)
            if tol is not None and dist < tol:
                break
            un, ue = (dn / dist, de / dist) if dist > 1e-9 else (0.0, 0.0)
            s = self.vn * un + self.ve * ue
            if math.hypot(self.vn - s * un, self.ve - s * ue) > _TURN_MPS:
                dt = min(_TURN_DT_S, duration - t)
                k = Kinematics(self.n, self.e, 0.0)
                k.vn, k.ve = self.vn, self.ve
                k.fly_to(tn, te, 0.0, dt, m.limits)
                self.n, self.e, self.vn, self.ve = k.n, k.e, k.vn, k.ve
                v2 += (k.vn * k.vn + k.ve * k.ve) * dt
                t += dt
                continue
            prof = Profile(dist, s, m.max_speed_mps, m.accel_mps2)
            step = duration - t if tol is None else min(prof.time_within(tol), duration - t)
            x, v, v2_step = prof.at(step)
            self.n, self.e = tn - un * (dist - x), te - ue * (dist - x)
            self.vn, self.ve = un * v, ue * v
            return t + step, v2 + v2_step
        return (t if tol is not None else duration), v2

    # -- vertical -----------------------------------------------------------------------------
    def _vertical_profile(self) -> tuple[Profile, float] | None:
        if self.target_h is None:
            return None
        m, rest = self.model, self.target_h - self.h
        sign = 1.0 if rest >= 0 else -1.0
        cap = m.max_climb_mps if sign > 0 else m.max_descent_mps
        return Profile(abs(rest), self.vz * sign, cap, m.accel_z_mps2), sign

    def _vertical_time_within(self, tol: float) -> float:
        vp = self._vertical_profile()
        return 0.0 if vp is None else vp[0].time_within(tol)

    # -- time passing -------------------------------------------------------------------------
    def advance(self, duration: float) -> None:
        if duration <= 0:
            return
        m = self.model
        if not self.in_air:
            self.charge_as += (
                m.armed_idle_current_a if self.armed else m.idle_current_a
            ) * duration
            return
        vp = self._vertical_profile()
        slow = 0.0  # time in the slow last stage of a landing (drawn as hovering)
        if self.landing and vp is not None:
            total = vp[0].duration + self.land_extra_s
            touchdown = total <= duration
            flying = min(duration, vp[0].duration)
            slow = min(duration, total) - flying
            self.land_extra_s -= slow
        else:
            touchdown, flying = False, duration
        _, v2 = self._horizontal(flying)
        climb = 0.0
        if vp is not None:
            prof, sign = vp
            x, v, _ = prof.at(flying)
            self.h += sign * x
            self.vz = sign * v
            climb = sign * x
        if m.flight_current_a is not None:
            self.charge_as += m.flight_current_a * (flying + slow)
        else:
            hover = m.hover_current_a
            self.charge_as += hover * (flying + slow) + hover * _FORWARD * v2 / m.max_speed_mps**2
            self.charge_as += hover * (_CLIMB * climb if climb > 0 else _DESCENT * climb)
        if touchdown:  # on the ground: the vehicle disarms itself
            self.h = self.vz = self.vn = self.ve = 0.0
            self.in_air = self.armed = self.landing = False
            self.target = self.target_h = None
            self.land_extra_s = 0.0
            self.charge_as += m.idle_current_a * (duration - flying - slow)

    def wait_time(self, step: dict[str, Any]) -> float:
        """Seconds until the goal is reached (Algorithm 1), on the worker's polling grid."""
        m = self.model
        if self.landing:
            vp = self._vertical_profile()
            t = vp[0].duration + self.land_extra_s if vp else 0.0
        else:
            tol_h = step.get("horizontal_tolerance_m") or m.horizontal_tolerance_m
            tol_v = step.get("vertical_tolerance_m") or m.vertical_tolerance_m
            probe = replace(self, notes=[])
            t_h, _ = probe._horizontal(math.inf, tol_h)
            t = max(t_h, self._vertical_time_within(tol_v))
        return math.ceil(t / m.poll_s - 1e-9) * m.poll_s if t > 0 else 0.0

    # -- steps --------------------------------------------------------------------------------
    def goal(self) -> tuple[float, float, float]:
        n, e = self.target if self.target is not None else (self.n, self.e)
        return n, e, self.target_h if self.target_h is not None else self.h

    def go(self, n: float, e: float, h: float, what: str) -> None:
        if not self.armed:
            self.notes.append(f"{what} while not armed: the drone would refuse it")
            return
        self.target, self.target_h = (n, e), h
        self.in_air, self.landing = True, False

    def stop_point(self) -> tuple[float, float]:
        k = math.hypot(self.vn, self.ve) / (2 * self.model.accel_mps2)
        return self.n + self.vn * k, self.e + self.ve * k

    def run(self, step: dict[str, Any], home: LLA) -> float:
        """Apply one step; returns its duration (vehicle seconds)."""
        m, command = self.model, step.get("command")
        duration = 0.0
        if command == "arm" and not self.armed:
            duration = m.arming_s
            self.advance(duration)  # idle current while arming
            self.armed = True
            return duration
        if command == "takeoff":
            height = step.get("value") or m.takeoff_altitude_m
            n, e = self.stop_point() if self.in_air else (self.n, self.e)
            self.go(n, e, height, "takeoff")
        elif command == "navigate":
            ned = lla_to_ned(LLA(step["lat"], step["lon"], home.alt_m), home)
            height = step.get("altitude_delta")
            self.go(ned.n, ned.e, self.goal()[2] if height is None else height, "navigate")
        elif command in ("changeN", "changeE", "altitude"):
            n, e, h = self.goal()
            value = float(step.get("value") or 0.0)
            n += value if command == "changeN" else 0.0
            e += value if command == "changeE" else 0.0
            self.go(n, e, h + (value if command == "altitude" else 0.0), command)
        elif command == "land" and self.in_air:
            self.target, self.target_h, self.landing = self.stop_point(), 0.0, True
            if m.land_speed_mps and m.land_speed_mps < m.max_descent_mps:
                low = min(self.h, m.land_alt_low_m)
                self.land_extra_s = low / m.land_speed_mps - low / m.max_descent_mps
        elif command == "disarm" and not self.in_air:
            self.armed = False
        elif command == "wait_for_flight":
            duration = self.wait_time(step)
        elif command in ("sleep", "read_sensors"):
            duration = float(step.get("value") or 0.0)
        elif command == "takepic":
            duration = m.picture_s
        self.advance(duration)
        return duration


@dataclass(frozen=True)
class Estimate:
    """Predicted flight time and battery use of a list of steps."""

    duration_s: float
    energy_mah: float
    battery_used_pct: float
    battery_end_pct: float
    per_step: list[float]
    per_step_mah: list[float] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


class Verdict(NamedTuple):
    ok: bool
    reason: str


def estimate(
    steps: list[dict[str, Any]],
    start: LLA,
    home: LLA,
    *,
    airborne: bool,
    battery_pct: float = 100.0,
    model: VehicleModel = DEFAULT_MODEL,
) -> Estimate:
    """Time and battery for a drone at ``start`` (home ``home``) to fly ``steps``.

    An airborne drone is taken to hover at ``start`` (armed, at ``start``'s height above home);
    one on the ground is taken as disarmed unless the steps never arm it.
    """
    here = lla_to_ned(start, home)
    state = _State(model, n=here.n, e=here.e, h=max(0.0, -here.d) if airborne else 0.0)
    if airborne:
        state.armed = state.in_air = True
        state.target, state.target_h = (here.n, here.e), state.h
    elif not any(s.get("command") == "arm" for s in steps):
        state.armed = True  # armed by someone else: do not charge arming it never asked for
    per_step: list[float] = []
    per_step_mah: list[float] = []
    cache: dict[tuple, Replay] = {}  # repeated units, flown once (estimate_units.py)
    keys = Keys()
    found = Units(steps, home, keys)
    known: int | None = None  # the state's key part when the last unit was replayed
    i = 0
    while i < len(steps):
        k = found.at.get(i)
        if k is not None:
            unit = found.items[k]
            replay = fly_unit(state, found.targets[k], unit, steps, home, cache, keys, known)
            per_step.extend(replay.seconds)
            per_step_mah.extend(replay.mah)
            known = replay.state_key
            i = unit.end
            continue
        before = state.charge_as
        per_step.append(state.run(steps[i], home))
        per_step_mah.append((state.charge_as - before) / 3.6)
        known = None
        i += 1
    energy = state.charge_as / 3.6
    used = 100.0 * energy / model.capacity_mah
    return Estimate(
        duration_s=sum(per_step),
        energy_mah=energy,
        battery_used_pct=used,
        battery_end_pct=battery_pct - used,
        per_step=per_step,
        per_step_mah=per_step_mah,
        notes=state.notes,
    )


def can_finish(est: Estimate, reserve_pct: float = 20.0) -> Verdict:
    """Whether the battery ends above ``reserve_pct``; the reason either way."""
    start = est.battery_end_pct + est.battery_used_pct
    if est.battery_end_pct >= reserve_pct:
        return Verdict(True, f"ends at {est.battery_end_pct:.1f}% (reserve {reserve_pct:g}%)")
    return Verdict(
        False,
        f"needs {est.battery_used_pct:.1f}% of the battery for {est.duration_s:.0f} s of flight"
        f" and has {start:.1f}%: it would end at {est.battery_end_pct:.1f}%, below the"
        f" {reserve_pct:g}% reserve",
    )
