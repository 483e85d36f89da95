"""The one contract every flight-controller backend fulfils (docs/DESIGN.md §5).

The Drone Controller, Mission Worker and Arming Switch call only this; they never know whether the
vehicle is simulated in-process, an ArduPilot over MAVLink or a dRonin over UAVTalk. State getters
return the latest known values without blocking; commands are coroutines that return once the
autopilot has accepted them (``arm`` returns once armed) and raise :class:`FcError` with the
autopilot's reason when refused.
"""

from __future__ import annotations

from collections.abc import AsyncIterator
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, Protocol, runtime_checkable

from dronefleet.clock import Clock
from dronefleet.errors import Conflict, Failed
from dronefleet.geo.types import LLA, NED


class FcError(Failed, RuntimeError):
    """A flight-controller command that was refused or failed; the message says why."""


class FcRefused(FcError, Conflict):
    """A command the vehicle will not take in its state, as a policy (disarm in flight without
    ``force``, a target above the altitude limit): a refusal, not a failure."""


class FlightMode(StrEnum):
    STABILIZE = "STABILIZE"
    GUIDED = "GUIDED"  # following position targets
    HOLD = "HOLD"  # holding position
    LAND = "LAND"
    RTL = "RTL"
    MISSION = "MISSION"  # flying an uploaded mission on board (MAVLink AUTO)


@dataclass(frozen=True, slots=True)
class BatteryState:
    remaining_pct: float
    voltage_v: float
    current_a: float
    consumed_mah: float
    capacity_mah: float
    cell_count: int


@dataclass(frozen=True, slots=True)
class Attitude:
    roll_deg: float
    pitch_deg: float
    yaw_deg: float


@dataclass(frozen=True, slots=True)
class VehicleState:
    armed: bool
    arming: bool  # an arm request is in progress
    in_air: bool
    mode: FlightMode
    landing: bool = False


class GpsFix(StrEnum):
    """The GPS receiver's fix, as MAVLink's GPS_FIX_TYPE and UAVTalk's GPSPosition.Status say."""

    NO_GPS = "no_gps"
    NO_FIX = "no_fix"
    FIX_2D = "2d"
    FIX_3D = "3d"  # 3-D and better (DGPS, RTK): a position to fly on

    @property
    def usable(self) -> bool:
        return self is GpsFix.FIX_3D


@dataclass(frozen=True, slots=True)
class GpsState:
    """What the GPS receiver reports: its fix, the satellites it uses, its horizontal dilution."""

    fix: GpsFix
    satellites: int
    hdop: float | None = None


@dataclass(frozen=True, slots=True)
class WindEstimate:
    """The wind the autopilot estimates (ArduPilot's WIND message): speed over the ground and
    where it blows from (0 = north), meteorological convention."""

    speed_mps: float
    from_deg: float


@runtime_checkable
class FlightController(Protocol):
    """What the Drone Controller needs from an autopilot.

    Backends may also offer ``gps() -> GpsState`` and ``wind() -> WindEstimate | None`` (None:
    the autopilot estimates no wind); the Drone Controller puts them in its heartbeats when
    there, for the pre-flight checks (ground/planner/preflight.py)."""

    @property
    def clock(self) -> Clock:
        """The vehicle's clock: sim time, or the autopilot's boot time."""
        ...

    async def connect(self) -> None: ...

    async def close(self) -> None: ...

    # -- commands ----------------------------------------------------------------------------
    async def arm(self) -> None:
        """Arm; returns once armed (the seed's dRonin took 3 s)."""
        ...

    async def disarm(self, *, force: bool = False) -> None:
        """Disarm; refused in flight unless ``force``."""
        ...

    async def takeoff(self, altitude_m: float) -> None:
        """Climb to ``altitude_m`` above home; returns once the climb has started."""
        ...

    async def land(self) -> None: ...

    async def goto(self, target: LLA) -> None:
        """Fly to ``target`` (altitude AMSL); returns once the target is accepted."""
        ...

    async def hold(self) -> None: ...

    async def reboot(self, *, force: bool = False) -> None:
        """Restart the autopilot; refused in flight unless ``force``."""
        ...

    async def rebuild_telemetry(self) -> None: ...

    async def request_object(self, name: str) -> dict[str, Any]:
        """The latest value of a named flight object (UAVObject / MAVLink message)."""
        ...

    # -- latest state (never blocks) ---------------------------------------------------------
    def position(self) -> LLA: ...

    def home(self) -> LLA: ...

    def velocity(self) -> NED:
        """Velocity in m/s, north-east-down."""
        ...

    def battery(self) -> BatteryState: ...

    def attitude(self) -> Attitude: ...

    def state(self) -> VehicleState: ...

    def telemetry(self) -> AsyncIterator[dict[str, float]]:
        """Flat numeric telemetry samples as they come (async generator)."""
        ...


def telemetry_sample(fc: FlightController, vehicle_time_s: float | None = None) -> dict[str, float]:
    """The flat numeric sample every backend streams, built from the protocol's own getters."""
    fix, home, vel = fc.position(), fc.home(), fc.velocity()
    att, bat, state = fc.attitude(), fc.battery(), fc.state()
    return {
        "vehicle_time_s": fc.clock.now() if vehicle_time_s is None else vehicle_time_s,
        "lat": fix.lat,
        "lon": fix.lon,
        "alt_m": fix.alt_m,
        "relative_alt_m": fix.alt_m - home.alt_m,
        "vn": vel.n,
        "ve": vel.e,
        "vd": vel.d,
        "roll_deg": att.roll_deg,
        "pitch_deg": att.pitch_deg,
        "yaw_deg": att.yaw_deg,
        "battery_pct": bat.remaining_pct,
        "voltage_v": bat.voltage_v,
        "current_a": bat.current_a,
        "armed": float(state.armed),
        "in_air": float(state.in_air),
    }
