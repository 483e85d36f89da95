"""How the vehicle moves towards its target (:class:`_Motion`): horizontally along trapezoidal
legs (:class:`.Profile`), the few seconds of a turn stepped with the simulator's own position
controller, the wind taking ground speed where the airspeed is at its limit; vertically, climb
and descent (a landing's at its land speeds), at the same time."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from dronefleet.ground.planner.estimate.profile import Profile
from dronefleet.ground.planner.estimate.vehicle import VehicleModel
from dronefleet.vehicle.kinematics import Kinematics

_TURN_MPS = 0.25  # speed across the leg above which the turn is stepped, not solved
_TURN_DT_S = 0.05  # the sim world's step
_CRAWL_MPS = 0.5  # the least ground speed assumed against a wind it can barely fly


@dataclass
class _Motion:
    """Where the vehicle is, how fast it moves, and where it is going (heights above home)."""

    model: VehicleModel
    n: float = 0.0
    e: float = 0.0
    vn: float = 0.0
    ve: float = 0.0
    h: float = 0.0  # height above home
    vz: float = 0.0  # up
    target: tuple[float, float] | None = None
    target_h: float | None = None
    landing: bool = False
    notes: list[str] = field(default_factory=list)
    speed_cap: float | None = None  # the leg's speed when slower than the model's (RTL_SPEED)
    #: The turn stepped last (see :meth:`_horizontal`): where it began, and where it was after
    #: its last step (the time before that step, then time, ∫airspeed², n, e, vn, ve).
    turned: tuple[tuple, tuple] | None = field(default=None, repr=False, compare=False)

    # -- horizontal ---------------------------------------------------------------------------
    def _cap_along(self, un: float, ue: float) -> float:
        """The ground speed along (un, ue): the leg's cap, less what the wind takes where the
        vehicle's airspeed is at its limit (sim/wind.py's limit_airspeed, closed form)."""
        m = self.model
        cap = self.speed_cap or m.max_speed_mps
        wn, we = m.wind_n_mps, m.wind_e_mps
        if not (wn or we):
            return cap
        uw = un * wn + ue * we
        disc = m.airspeed_cap_mps**2 - (wn * wn + we * we) + uw * uw
        along = uw + math.sqrt(disc) if disc > 0 else 0.0
        if along < _CRAWL_MPS:
            note = f"the wind ({m.wind_mps:.1f} m/s) is too strong to fly against: estimate unsure"
            if note not in self.notes:
                self.notes.append(note)
            return _CRAWL_MPS
        return min(cap, along)

    def _where(self) -> tuple:
        """What a turn stepped from here depends on (besides the model and the time)."""
        return (self.n, self.e, self.vn, self.ve, self.target, self.speed_cap)

    def _horizontal(self, duration: float, tol: float | None = None) -> tuple[float, float]:
        """Fly for ``duration`` s or until within ``tol``; returns (time, ∫airspeed² dt).

        A turn is stepped twice when a ``wait_for_flight`` is: once to find when the vehicle is
        within the tolerance (a probe, with ``tol``), once flying that long. Its steps are the
        same both times while each is a whole step (``_TURN_DT_S``), so the flight starts where
        the probe's last step ended (``turned``), from where the probe began."""
        m, t, a2 = self.model, 0.0, 0.0
        wn, we = m.wind_n_mps, m.wind_e_mps
        w2 = wn * wn + we * we
        began, t_last = self._where(), -1.0  # t_last: the time before the last turn step
        turned, self.turned = self.turned, None
        resume = tol is None and turned is not None and turned[0] == began
        if resume and turned and duration - turned[1][0] >= _TURN_DT_S:  # all whole steps
            t_last, t, a2, self.n, self.e, self.vn, self.ve = turned[1]
        while self.target is not None and duration - t > 1e-12:
            tn, te = self.target
            dn, de = tn - self.n, te - self.e
            dist = math.hypot(dn, de)
            if tol is not None and dist < tol:
                break
            un, ue = (dn / dist, de / dist) if dist > 1e-9 else (0.0, 0.0)
            s = self.vn * un + self.ve * ue
            if math.hypot(self.vn - s * un, self.ve - s * ue) > _TURN_MPS:
                t_last, t, a2 = self._turn(duration, tol, t_last, t, a2)
                continue
            self._turned(tol, began, t_last, t, a2)
            prof = Profile(dist, s, self._cap_along(un, ue), m.accel_mps2)
            step = duration - t if tol is None else min(prof.time_within(tol), duration - t)
            x, v, v2_step = prof.at(step)
            self.n, self.e = tn - un * (dist - x), te - ue * (dist - x)
            self.vn, self.ve = un * v, ue * v
            # (v·u - w)² integrated: ∫v² - 2 (u·w) ∫v + |w|² t, with ∫v = x along the leg.
            a2 += v2_step - 2.0 * (un * wn + ue * we) * x + w2 * step
            return t + step, a2
        self._turned(tol, began, t_last, t, a2)
        if tol is not None:
            return t, a2
        return duration, a2 + w2 * (duration - t)

    def _turn(
        self, duration: float, tol: float | None, t_last: float, t: float, a2: float
    ) -> tuple[float, float, float]:
        """Step a turn with the simulator's position controller while there is speed across
        the leg (the steps :meth:`_horizontal` would take one by one, in local variables);
        returns the time before the last step, the time and ∫airspeed² dt."""
        m, hypot, (tn, te) = self.model, math.hypot, self.target or (self.n, self.e)
        wn, we = m.wind_n_mps, m.wind_e_mps
        limits = m.limits
        if self.speed_cap:
            limits = replace(limits, max_speed_mps=self.speed_cap)
        n, e, vn, ve = self.n, self.e, self.vn, self.ve
        k = Kinematics(n, e, 0.0)  # where the vehicle is, step after step
        k.vn, k.ve = vn, ve
        while duration - t > 1e-12:
            dn, de = tn - n, te - e
            dist = hypot(dn, de)
            if tol is not None and dist < tol:
                break
            un, ue = (dn / dist, de / dist) if dist > 1e-9 else (0.0, 0.0)
            s = vn * un + ve * ue
            if hypot(vn - s * un, ve - s * ue) <= _TURN_MPS:
                break
            dt = min(_TURN_DT_S, duration - t)
            k.fly_to(tn, te, 0.0, dt, limits, wn, we)
            n, e, vn, ve = k.n, k.e, k.vn, k.ve
            a2 += ((vn - wn) ** 2 + (ve - we) ** 2) * dt
            t_last, t = t, t + dt
        self.n, self.e, self.vn, self.ve = n, e, vn, ve
        return t_last, t, a2

    def _turned(self, tol: float | None, began: tuple, t_last: float, t: float, a2: float) -> None:
        if tol is not None and t_last >= 0.0:  # a probe stepped a turn: where its last step ended
            self.turned = (began, (t_last, t, a2, self.n, self.e, self.vn, self.ve))

    # -- vertical -----------------------------------------------------------------------------
    def _land_fast_mps(self) -> float:
        """A landing's descent above LAND_ALT_LOW: LAND_SPEED_HIGH, else WPNAV_SPEED_DN."""
        m = self.model
        return m.land_speed_high_mps or m.max_descent_mps

    def _vertical_profile(self) -> tuple[Profile, float] | None:
        if self.target_h is None:
            return None
        m, rest = self.model, self.target_h - self.h
        sign = 1.0 if rest >= 0 else -1.0
        cap = m.max_climb_mps if sign > 0 else m.max_descent_mps
        if sign < 0 and self.landing:
            cap = self._land_fast_mps()
        return Profile(abs(rest), self.vz * sign, cap, m.accel_z_mps2), sign

    def _vertical_time_within(self, tol: float) -> float:
        vp = self._vertical_profile()
        return 0.0 if vp is None else vp[0].time_within(tol)

    # -- where it stops, where it goes ------------------------------------------------------
    def stop_point(self) -> tuple[float, float]:
        k = math.hypot(self.vn, self.ve) / (2 * self.model.accel_mps2)
        return self.n + self.vn * k, self.e + self.ve * k

    def goal(self) -> tuple[float, float, float]:
        n, e = self.target if self.target is not None else (self.n, self.e)
        return n, e, self.target_h if self.target_h is not None else self.h
