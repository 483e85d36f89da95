"""A drone's settings: identity, timings, tolerances, limits, thresholds, folders."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class DroneConfig:
    drone_id: str
    heartbeat_interval_s: float = 5.0  # vehicle seconds (seed 4.1.2)
    takeoff_altitude_m: float = 10.0
    max_altitude_m: float = 120.0
    horizontal_tolerance_m: float = 2.0  # Algorithm 1
    vertical_tolerance_m: float = 2.0
    wait_poll_s: float = 0.05  # vehicle seconds between position checks in wait_for_flight
    gear_timeout_s: float = 10.0  # wall seconds
    # Telemetry is sampled at 5 Hz of vehicle time; a sped-up vehicle would multiply that in wall
    # time and flood the broker, so at most this many messages per wall second are sent.
    telemetry_max_wall_hz: float = 10.0
    battery_critical_pct: float = 20.0  # CRITICAL alarm: the ground replaces the drone
    # Below these the drone acts by itself (drone/battery_guard.py): home, then land here.
    battery_rtl_pct: float = 12.0
    battery_land_pct: float = 6.0
    # Fly eligible missions on board (MAVLink AUTO) unless a mission asks otherwise
    # (``MissionRequest.onboard``); ``dronefleet drone --onboard-missions``.
    onboard_missions: bool = False
    # What a running mission does when the broker link has been down link_loss_timeout_s
    # vehicle seconds (drone/link_loss.py): "continue" (default), "hold" or "rtl";
    # ``dronefleet drone --link-loss``.
    link_loss_action: str = "continue"
    link_loss_timeout_s: float = 5.0
    sensor_bounds: dict[str, tuple[float | None, float | None]] = field(
        default_factory=lambda: {"co2_ppm": (None, 1000.0)}
    )
    log_dir: Path | None = None
    state_dir: Path | None = None  # mission reports kept on disk (drone/report_store.py)
    gear_dir: Path | None = None
