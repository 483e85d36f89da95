"""The GPS receiver: a position fix every 0.2 s of vehicle time (5 Hz), optionally noisy.

The fix is a sample of the true position at the fix time plus seeded Gaussian noise (``noise_m``
one sigma horizontally, 1.5 sigma vertically as real receivers are worse in height). The LLA of a
fix is computed only when read, so idle vehicles cost nothing.
"""

from __future__ import annotations

import random

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED

_EPS_S = 1e-9
_VERTICAL_NOISE_FACTOR = 1.5


class GpsReceiver:
    """Samples a vehicle's NED position at ``rate_hz`` and turns it into LLA fixes."""

    def __init__(
        self,
        home: LLA,
        rate_hz: float = 5.0,
        noise_m: float = 0.0,
        seed: int | None = None,
        satellites: int = 12,
        hdop: float = 0.8,
    ) -> None:
        if rate_hz <= 0:
            raise ValueError("GPS rate must be positive")
        self.home = home
        self.period_s = 1.0 / rate_hz
        self.noise_m = noise_m
        self.satellites = satellites
        self.hdop = hdop
        self._rng = random.Random(seed)
        self._fix_ned = NED(0.0, 0.0, 0.0)
        self._fix_lla: LLA | None = None
        self.fix_time_s = float("-inf")
        self.fix_count = 0

    def update(self, time_s: float, n: float, e: float, d: float) -> bool:
        """Take a fix if one is due at ``time_s``; returns True when a new fix was taken."""
        if time_s < self.fix_time_s + self.period_s - _EPS_S:
            return False
        if self.noise_m > 0:
            sigma = self.noise_m
            n += self._rng.gauss(0.0, sigma)
            e += self._rng.gauss(0.0, sigma)
            d += self._rng.gauss(0.0, sigma * _VERTICAL_NOISE_FACTOR)
        self._fix_ned = NED(n, e, d)
        self._fix_lla = None
        # Stay on the 5 Hz grid even when stepped coarsely.
        if self.fix_time_s == float("-inf"):
            self.fix_time_s = time_s
        else:
            periods = int((time_s - self.fix_time_s + _EPS_S) / self.period_s)
            self.fix_time_s += periods * self.period_s
        self.fix_count += 1
        return True

    @property
    def fix_ned(self) -> NED:
        return self._fix_ned

    @property
    def fix_lla(self) -> LLA:
        if self._fix_lla is None:
            self._fix_lla = ned_to_lla(self._fix_ned, self.home)
        return self._fix_lla
