"""Flight-controller state as the wire describes it (FlightState, Position)."""

from __future__ import annotations

from dronefleet.geo.types import LLA
from dronefleet.messaging.common import Position
from dronefleet.messaging.status import FlightState
from dronefleet.vehicle.base import VehicleState


def flight_state(state: VehicleState) -> FlightState:
    if state.landing and state.in_air:
        return FlightState.LANDING
    if state.in_air:
        return FlightState.FLYING
    if state.armed:
        return FlightState.ARMED
    if state.arming:
        return FlightState.ARMING
    return FlightState.DISARMED


def position_of(lla: LLA, home: LLA) -> Position:
    return Position(
        lat=lla.lat,
        lon=lla.lon,
        alt_m=round(lla.alt_m, 3),
        relative_alt_m=round(lla.alt_m - home.alt_m, 3),
    )
