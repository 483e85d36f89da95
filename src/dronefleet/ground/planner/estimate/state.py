"""The vehicle as the estimator flies it through mission steps (:class:`_State`): armed or not,
in the air, landing, flying home stage by stage, and the charge drawn while time passes
(:meth:`_State.advance`); :meth:`_State.run` applies one step and says how long it took, a
``wait_for_flight`` ending inside the tolerance cylinder (Algorithm 1) on the Mission Worker's
polling."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.estimate.draw import charged_in_air
from dronefleet.ground.planner.estimate.homing import Phase, rtl_path
from dronefleet.ground.planner.estimate.motion import _Motion


@dataclass
class _State(_Motion):
    """Where the vehicle is (:class:`._Motion`), whether it is armed and flying, what it drew."""

    armed: bool = False
    in_air: bool = False
    land_extra_s: float = 0.0  # the slow last stage of a landing, beyond the profile
    charge_as: float = 0.0  # ampere-seconds drawn
    homing: list[Phase] = field(default_factory=list)  # the flight home still to fly
    phase_s: float = 0.0  # seconds into the current stage of it

    # -- time passing -------------------------------------------------------------------------
    def advance(self, duration: float) -> None:
        """``duration`` seconds pass: the vehicle flies on (home, stage by stage, if homing)."""
        while self.homing:
            left = self._phase_left()
            if left > duration + 1e-12:
                break
            self._fly(max(left, 0.0))
            duration -= max(left, 0.0)
            self._next_phase()
        self._fly(duration)
        self.phase_s += max(duration, 0.0)

    def _fly(self, duration: float) -> None:
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
        _, a2 = self._horizontal(flying)
        climb = 0.0
        if vp is not None:
            prof, sign = vp
            x, v, _ = prof.at(flying)
            self.h += sign * x
            self.vz = sign * v
            climb = sign * x
        self.charge_as = charged_in_air(self.charge_as, m, flying, slow, a2, climb)
        if touchdown:  # on the ground: the vehicle disarms itself
            self.h = self.vz = self.vn = self.ve = 0.0
            self.in_air = self.armed = self.landing = False
            self.target = self.target_h = None
            self.land_extra_s = 0.0
            self.homing = []
            self.charge_as += m.idle_current_a * (duration - flying - slow)

    # -- the flight home (rtl) ----------------------------------------------------------------
    def start_rtl(self) -> None:
        """The vehicle's RTL from here (see :class:`VehicleModel`'s ``native_rtl``)."""
        self.speed_cap = None
        if not self.in_air:  # an RTL on the ground only makes the vehicle safe
            self.armed = False if self.model.native_rtl else self.armed
            return
        self.homing, note = rtl_path(self.model, self.h, self.stop_point())
        if note:
            self.notes.append(note)
        self._begin_phase()

    def _begin_phase(self) -> None:
        self.phase_s = 0.0
        if not self.homing:
            self.speed_cap = None
            return
        phase = self.homing[0]
        if phase.kind == "go":
            self.target, self.target_h = (phase.n, phase.e), phase.h
            self.speed_cap, self.landing = phase.speed, False
        elif phase.kind == "land":
            self.start_landing()

    def _next_phase(self) -> None:
        if self.homing:
            self.homing.pop(0)
        self._begin_phase()

    def _phase_left(self) -> float:
        """Seconds until the current stage of the flight home is done."""
        phase = self.homing[0]
        if phase.kind == "loiter":
            left = 0.0
        elif phase.kind == "land":
            if not self.in_air:
                return 0.0
            vp = self._vertical_profile()
            return (vp[0].duration if vp else 0.0) + self.land_extra_s
        else:
            probe = replace(self, notes=[], homing=[])
            t_h, _ = probe._horizontal(math.inf, phase.tol_h)
            left = max(t_h, self._vertical_time_within(phase.tol_v))
        return max(left, phase.least_s - self.phase_s)

    def finish_homing(self) -> float:
        """Fly the rest of the way home; the seconds it took."""
        took = 0.0
        while self.homing:
            left = self._phase_left()
            self.advance(left)
            took += left
        return took

    def start_landing(self) -> None:
        """Land where it stops (ArduPilot's LAND: LAND_SPEED_HIGH/WPNAV_SPEED_DN down to
        LAND_ALT_LOW, then LAND_SPEED, then its land detector)."""
        m = self.model
        self.target, self.target_h, self.landing = self.stop_point(), 0.0, True
        self.speed_cap = None
        fast = self._land_fast_mps()
        self.land_extra_s = m.land_detect_s
        if m.land_speed_mps and m.land_speed_mps < fast:
            low = min(self.h, m.land_alt_low_m)
            self.land_extra_s += low / m.land_speed_mps - low / fast

    def wait_time(self, step: dict[str, Any]) -> float:
        """Seconds until the goal is reached (Algorithm 1), on the worker's polling grid."""
        m = self.model
        if self.landing:
            vp = self._vertical_profile()
            t = vp[0].duration + self.land_extra_s if vp else 0.0
        else:
            tol_h = step.get("horizontal_tolerance_m") or m.horizontal_tolerance_m
            tol_v = step.get("vertical_tolerance_m") or m.vertical_tolerance_m
            probe = object.__new__(type(self))  # what replace(self, notes=[]) makes, sooner
            probe.__dict__.update(self.__dict__, notes=[])
            t_h, _ = probe._horizontal(math.inf, tol_h)
            self.turned = probe.turned  # the flight that follows starts where its turn ended
            t = max(t_h, self._vertical_time_within(tol_v))
        return self._on_grid(t)

    def _on_grid(self, t: float) -> float:
        poll = self.model.poll_s
        return math.ceil(t / poll - 1e-9) * poll if t > 0 else 0.0

    # -- steps --------------------------------------------------------------------------------
    def go(self, n: float, e: float, h: float, what: str) -> None:
        if not self.armed:
            self.notes.append(f"{what} while not armed: the drone would refuse it")
            return
        self.target, self.target_h = (n, e), h
        self.in_air, self.landing = True, False
        self.homing, self.speed_cap = [], None  # a new destination ends a flight home

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
            self.homing = []
            self.start_landing()
        elif command == "rtl":
            self.start_rtl()
        elif command == "disarm" and not self.in_air:
            self.armed = False
        elif command == "wait_for_flight" and self.homing:  # until down at home
            flown = self.finish_homing()
            duration = self._on_grid(flown)
            self.advance(duration - flown)
            return duration
        elif command == "wait_for_flight":
            duration = self.wait_time(step)
        elif command in ("sleep", "read_sensors"):
            duration = float(step.get("value") or 0.0)
        elif command == "takepic":
            duration = m.picture_s
        self.advance(duration)
        return duration
