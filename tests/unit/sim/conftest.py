"""Helpers for the simulated-vehicle scenarios: a home on the seed's test field and stepping."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from dronefleet.geo.types import LLA
from dronefleet.sim import SimVehicle

STEP_S = 0.05


@pytest.fixture
def home() -> LLA:
    return LLA(40.6300, -8.6580, 10.0)  # a field near Aveiro


@pytest.fixture
def vehicle(home: LLA) -> SimVehicle:
    return SimVehicle("QUAD_1", home)


@pytest.fixture
def fly() -> Callable[..., float]:
    """``fly(vehicle, until=predicate, timeout_s=60)`` steps until true; returns the sim seconds
    it took. Without ``until`` it steps ``for_s`` seconds."""

    def run(
        vehicle: SimVehicle,
        until: Callable[[], bool] | None = None,
        *,
        for_s: float | None = None,
        timeout_s: float = 120.0,
        on_step: Callable[[], None] | None = None,
    ) -> float:
        start = vehicle.time_s
        steps = round((for_s if for_s is not None else timeout_s) / STEP_S)
        for _ in range(steps):
            if until is not None and until():
                return vehicle.time_s - start
            vehicle.step(STEP_S)
            if on_step is not None:
                on_step()
        if until is not None and not until():
            raise AssertionError(f"not reached in {timeout_s} s: {vehicle!r}")
        return vehicle.time_s - start

    return run


@pytest.fixture
def armed(vehicle: SimVehicle, fly) -> SimVehicle:
    vehicle.arm()
    fly(vehicle, until=lambda: vehicle.armed)
    return vehicle


@pytest.fixture
def hovering(armed: SimVehicle, fly) -> SimVehicle:
    """QUAD_1 armed and hovering at 10 m above home."""
    armed.takeoff(10.0)
    fly(armed, until=lambda: armed.position_ned.d == -10.0 and armed.velocity_ned.d == 0.0)
    return armed
