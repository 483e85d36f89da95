"""The autopilot parameters the ``mavlink`` backend reads on connect, and the flight figures the
planner gets from them (:meth:`MavlinkFlightController.flight_params`).

Each figure is read under the first of its names the autopilot knows (ArduPilot's recent and
earlier names, then PX4's) and converted to SI units; :func:`flight_figures` leaves out the ones
that are unknown.
"""

from __future__ import annotations

#: Autopilot parameters read on connect, for the planner's estimates and the gear check: key in
#: Heartbeat.flight, then ArduPilot Copter's names with the factor to SI units. Recent ArduPilot
#: (the SITL this project tests, upstream 64a9c78) names them in SI units (WP_SPD m/s, WP_ACC
#: m/s², WP_JERK m/s³, LAND_SPD_MS, LAND_ALT_LOW_M); earlier versions in cm (WPNAV_SPEED cm/s,
#: WPNAV_ACCEL cm/s², LAND_SPEED, LAND_ALT_LOW cm). The first name the autopilot knows wins.
#: The way home (issue 28): RTL_ALT (cm; RTL_ALT_M), RTL_SPEED (cm/s, 0: WP_SPD; RTL_SPEED_MS),
#: RTL_ALT_FINAL (cm; RTL_ALT_FINAL_M), RTL_LOIT_TIME (ms), RTL_CONE_SLOPE, RTL_CLIMB_MIN (cm;
#: RTL_CLIMB_MIN_M), LAND_SPEED_HIGH (cm/s, 0: WP_SPD_DN; LAND_SPD_HIGH_MS). PX4's own names
#: where they mean the same (its parameter reference): MPC_XY_CRUISE (m/s, a mission's speed),
#: MPC_ACC_HOR (m/s²), MPC_JERK_AUTO (m/s³), MPC_Z_V_AUTO_UP/DN (m/s), MPC_LAND_SPEED (m/s,
#: below MPC_LAND_ALT2 m), BAT1_CAPACITY (mAh, -1 unknown), RTL_RETURN_ALT (m), RTL_LAND_DELAY
#: (s over home before landing; -1 for ever, left out). PX4's return cone (RTL_CONE_ANG, an
#: angle) is not ArduPilot's slope: the estimate keeps ArduPilot's, which climbs as high or
#: higher.
FLIGHT_PARAMS: tuple[tuple[str, tuple[tuple[str, float], ...]], ...] = (
    ("speed_mps", (("WP_SPD", 1.0), ("WPNAV_SPEED", 0.01), ("MPC_XY_CRUISE", 1.0))),
    ("accel_mps2", (("WP_ACC", 1.0), ("WPNAV_ACCEL", 0.01), ("MPC_ACC_HOR", 1.0))),
    ("accel_z_mps2", (("WP_ACC_Z", 1.0), ("WPNAV_ACCEL_Z", 0.01))),
    ("jerk_mps3", (("WP_JERK", 1.0), ("WPNAV_JERK", 1.0), ("MPC_JERK_AUTO", 1.0))),
    ("climb_mps", (("WP_SPD_UP", 1.0), ("WPNAV_SPEED_UP", 0.01), ("MPC_Z_V_AUTO_UP", 1.0))),
    ("descent_mps", (("WP_SPD_DN", 1.0), ("WPNAV_SPEED_DN", 0.01), ("MPC_Z_V_AUTO_DN", 1.0))),
    ("land_speed_mps", (("LAND_SPD_MS", 1.0), ("LAND_SPEED", 0.01), ("MPC_LAND_SPEED", 1.0))),
    ("land_alt_low_m", (("LAND_ALT_LOW_M", 1.0), ("LAND_ALT_LOW", 0.01), ("MPC_LAND_ALT2", 1.0))),
    ("land_speed_high_mps", (("LAND_SPD_HIGH_MS", 1.0), ("LAND_SPEED_HIGH", 0.01))),
    ("capacity_mah", (("BATT_CAPACITY", 1.0), ("BAT1_CAPACITY", 1.0))),
    ("rtl_alt_m", (("RTL_ALT_M", 1.0), ("RTL_ALT", 0.01), ("RTL_RETURN_ALT", 1.0))),
    ("rtl_speed_mps", (("RTL_SPEED_MS", 1.0), ("RTL_SPEED", 0.01))),
    ("rtl_alt_final_m", (("RTL_ALT_FINAL_M", 1.0), ("RTL_ALT_FINAL", 0.01))),
    ("rtl_loiter_s", (("RTL_LOIT_TIME", 0.001), ("RTL_LAND_DELAY", 1.0))),
    ("rtl_cone_slope", (("RTL_CONE_SLOPE", 1.0),)),
    ("rtl_climb_min_m", (("RTL_CLIMB_MIN_M", 1.0), ("RTL_CLIMB_MIN", 0.01))),
    ("camera_type", (("CAM1_TYPE", 1.0),)),
)
#: Flight figures for which zero is a setting, not "unknown" (no loiter, no cone, ...).
ZERO_IS_A_SETTING = frozenset(
    {"rtl_alt_final_m", "rtl_loiter_s", "rtl_cone_slope", "rtl_climb_min_m"}
)


def flight_figures(params: dict[str, float]) -> dict[str, float]:
    """How this vehicle flies, from its parameters (SI units; for the planner)."""
    return {
        k: v
        for k, v in params.items()
        if k != "camera_type" and (v > 0 or (v == 0 and k in ZERO_IS_A_SETTING))
    }
