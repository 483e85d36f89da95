"""Where a drone will be, second by second, while it flies a list of mission steps (issue 14).

The Mission Planner (seed 4.2.4) already replays steps with the vehicle model to know how long
they take (:mod:`.estimate`); the separation check (:mod:`.separation`) needs the same replay as
a path in time. :func:`predict` flies the steps with the estimator's own state
(:class:`~dronefleet.ground.planner.estimate.state._State`: trapezoidal legs, climb while flying,
the Mission Worker's ``wait_for_flight`` polling, photo stops, holds, landing) and samples the
position every :data:`SAMPLE_S` vehicle seconds, so a predicted path and a predicted duration
can never disagree, the way home included (``rtl``: the autopilot's own RTL or the Navigation
Processor's, as :mod:`.estimate` flies it).

Positions are kept in one local frame for every drone of a check (north, east, up from an
``origin``), as numpy arrays on a uniform time grid that starts now, so two paths are compared
index by index (:func:`.separation.first_conflict`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dronefleet.geo.ned import lla_to_ned
from dronefleet.geo.types import LLA
from dronefleet.ground.planner.estimate import DEFAULT_MODEL, VehicleModel
from dronefleet.ground.planner.estimate.state import _State

#: Vehicle seconds between two samples of a predicted path. Conflicts between samples are
#: found exactly (the check interpolates linearly), so this only bounds the error of taking the
#: curved path between samples as straight (at 10 m/s and 2.5 m/s², a few centimetres).
SAMPLE_S = 0.5
#: Height of a flight home without the autopilot's own RTL: the drone's RTL_ALT_M
#: (drone/navigation.py, ArduPilot's RTL_ALT default); tests keep the two equal.
RTL_ALT_M = DEFAULT_MODEL.rtl_alt_m


@dataclass(frozen=True)
class Trajectory:
    """A drone's predicted path: sample ``k`` is at ``k * SAMPLE_S`` vehicle seconds from now.

    ``n_m``/``e_m``/``up_m`` are metres from the check's origin (up: above its altitude);
    ``in_air`` is False while the drone is on the ground (parked drones are not traffic). After
    the last sample the drone stays where it ended (hovering there, or on the ground).
    """

    drone_id: str
    n_m: np.ndarray
    e_m: np.ndarray
    up_m: np.ndarray
    in_air: np.ndarray
    delay_s: float = 0.0  # how long its start was held back (deconfliction)
    label: str = ""  # what was changed to get it (deconfliction), for notes

    @property
    def duration_s(self) -> float:
        return (len(self.n_m) - 1) * SAMPLE_S

    def delayed(self, delay_s: float) -> Trajectory:
        """The same path started ``delay_s`` later (rounded to samples): it waits where it is."""
        k = round(delay_s / SAMPLE_S)
        if k <= 0:
            return self

        def hold(a: np.ndarray) -> np.ndarray:
            return np.concatenate([np.full(k, a[0], dtype=a.dtype), a])

        return self._each(hold, delay_s=self.delay_s + k * SAMPLE_S)

    def advanced(self, early_s: float) -> Trajectory:
        """The same path ``early_s`` sooner (rounded to samples): its first samples dropped."""
        k = min(round(early_s / SAMPLE_S), len(self.n_m) - 1)
        if k <= 0:
            return self
        return self._each(lambda a: a[k:])

    def padded(self, length: int) -> Trajectory:
        """This path held at its last sample up to ``length`` samples."""
        extra = length - len(self.n_m)
        if extra <= 0:
            return self

        def hold(a: np.ndarray) -> np.ndarray:
            return np.concatenate([a, np.full(extra, a[-1], dtype=a.dtype)])

        return self._each(hold)

    def _each(
        self, change: Callable[[np.ndarray], np.ndarray], delay_s: float | None = None
    ) -> Trajectory:
        """This path with ``change`` made to each of its sampled arrays alike."""
        return Trajectory(
            self.drone_id,
            change(self.n_m),
            change(self.e_m),
            change(self.up_m),
            change(self.in_air),
            self.delay_s if delay_s is None else delay_s,
            self.label,
        )

    def at(self, t_s: float) -> tuple[float, float, float]:
        """North, east, up at ``t_s`` (held at the ends)."""
        k = min(max(round(t_s / SAMPLE_S), 0), len(self.n_m) - 1)
        return float(self.n_m[k]), float(self.e_m[k]), float(self.up_m[k])


@dataclass
class _Recorder(_State):
    """The estimator's state, sampling its position on the :data:`SAMPLE_S` grid as it goes."""

    clock_s: float = 0.0
    samples: list[tuple[float, float, float, bool]] = field(default_factory=list)

    def record(self) -> None:
        self.samples.append((self.n, self.e, self.h, self.in_air))

    def advance(self, duration: float) -> None:
        end = self.clock_s + max(duration, 0.0)
        while True:
            tick = (math.floor(self.clock_s / SAMPLE_S + 1e-9) + 1) * SAMPLE_S
            if tick > end + 1e-9:
                break
            super().advance(tick - self.clock_s)
            self.clock_s = tick
            self.record()
        super().advance(end - self.clock_s)
        self.clock_s = end


def predict(
    drone_id: str,
    steps: list[dict[str, Any]],
    *,
    start: LLA,
    home: LLA,
    airborne: bool,
    origin: LLA,
    model: VehicleModel = DEFAULT_MODEL,
) -> Trajectory:
    """The path of ``drone_id`` from ``start`` (home ``home``) flying ``steps``, starting now.

    As :func:`.estimate.estimate`: an airborne drone hovers at ``start`` until told otherwise;
    one on the ground is disarmed unless the steps never arm it."""
    here = lla_to_ned(start, home)
    state = _Recorder(model, n=here.n, e=here.e, h=max(0.0, -here.d) if airborne else 0.0)
    if airborne:
        state.armed = state.in_air = True
        state.target, state.target_h = (here.n, here.e), state.h
    elif not any(s.get("command") == "arm" for s in steps):
        state.armed = True
    state.record()
    for step in steps:
        state.run(step, home)
    state.finish_homing()  # an rtl nobody waits for: the vehicle still flies home
    # On to the next sample, so that the grid stays uniform to the end.
    last_s = (len(state.samples) - 1) * SAMPLE_S
    if state.clock_s > last_s + 1e-9:
        state.advance(last_s + SAMPLE_S - state.clock_s)
    data = np.asarray([s[:3] for s in state.samples], dtype=float)
    offset = lla_to_ned(LLA(home.lat, home.lon, home.alt_m), origin)
    return Trajectory(
        drone_id,
        data[:, 0] + offset.n,
        data[:, 1] + offset.e,
        data[:, 2] - offset.d,
        np.asarray([s[3] for s in state.samples], dtype=bool),
    )


def hovering(drone_id: str, position: LLA, *, origin: LLA) -> Trajectory:
    """A drone in the air that stays where it is (no mission: it holds)."""
    here = lla_to_ned(position, origin)
    one = np.asarray
    return Trajectory(drone_id, one([here.n]), one([here.e]), one([-here.d]), one([True]))
