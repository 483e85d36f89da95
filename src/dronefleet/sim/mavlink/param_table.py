"""ArduPilot Copter 4.5's parameters as a ground station reads them: name -> (default, type).

Data only (issue 10, item 3). Names and defaults are ArduPilot's, as its parameter reference lists
them ("Complete Parameter List", Copter 4.5, ardupilot.org/copter/docs/parameters.html) and as the
parameter definitions of ArduCopter and its libraries (AP_Param tables) declare them; each type is
the MAV_PARAM_TYPE ArduPilot sends for the kind of variable (AP_Int8 -> INT8, AP_Int16 -> INT16,
AP_Int32 -> INT32, AP_Float -> REAL32). Units are ArduPilot's (cm, cm/s, centidegrees, ms, mAh).
Board- and sensor-specific parameters, which a real autopilot adds for the hardware it finds,
are left out, as are the many tuning tables a ground station does not need to connect.

:data:`SIM_CONFIG` is how the simulated vehicle is set up where that differs from the firmware's
defaults: a configured quad X with a 5500 mAh analog battery monitor, climbing at the seed's 2 m/s.
"""

from __future__ import annotations

from dronefleet.protocols.mavlink.codec import dialect as mav

I8 = mav.MAV_PARAM_TYPE_INT8
I16 = mav.MAV_PARAM_TYPE_INT16
I32 = mav.MAV_PARAM_TYPE_INT32
F = mav.MAV_PARAM_TYPE_REAL32

_COPTER: dict[str, tuple[float, int]] = {
    "FORMAT_VERSION": (120, I16), "SYSID_THISMAV": (1, I16), "SYSID_MYGCS": (255, I16),
    "SYSID_ENFORCE": (0, I8), "PILOT_THR_FILT": (0, F), "PILOT_TKOFF_ALT": (0, F),
    "PILOT_THR_BHV": (0, I16), "PILOT_SPEED_UP": (250, I16), "PILOT_SPEED_DN": (0, I16),
    "PILOT_ACCEL_Z": (250, I16), "PILOT_Y_RATE": (202.5, F), "PILOT_Y_EXPO": (0, F),
    "PILOT_Y_RATE_TC": (0, F), "TELEM_DELAY": (0, I8), "GCS_PID_MASK": (0, I16),
    "RTL_ALT": (1500, I32), "RTL_CONE_SLOPE": (3, F), "RTL_SPEED": (0, I16),
    "RTL_ALT_FINAL": (0, I16), "RTL_CLIMB_MIN": (0, I16), "RTL_LOIT_TIME": (5000, I32),
    "RTL_ALT_TYPE": (0, I8), "RTL_OPTIONS": (0, I32), "RNGFND_GAIN": (0.8, F),
    "FS_GCS_ENABLE": (0, I8), "FS_GCS_TIMEOUT": (5, F), "FS_THR_ENABLE": (1, I8),
    "FS_THR_VALUE": (975, I16), "FS_EKF_ACTION": (1, I8), "FS_EKF_THRESH": (0.8, F),
    "FS_CRASH_CHECK": (1, I8), "FS_VIBE_ENABLE": (1, I8), "FS_OPTIONS": (0, I32),
    "GPS_HDOP_GOOD": (140, I16), "SUPER_SIMPLE": (0, I8), "WP_YAW_BEHAVIOR": (2, I8),
    "WP_NAVALT_MIN": (0, F), "LAND_SPEED": (50, I16), "LAND_SPEED_HIGH": (0, I16),
    "LAND_ALT_LOW": (1000, I16), "LAND_REPOSITION": (1, I8), "THR_DZ": (100, I16),
    "FLTMODE1": (0, I8), "FLTMODE2": (0, I8), "FLTMODE3": (0, I8), "FLTMODE4": (0, I8),
    "FLTMODE5": (0, I8), "FLTMODE6": (0, I8), "FLTMODE_CH": (5, I8), "SIMPLE": (0, I8),
    "INITIAL_MODE": (0, I8), "LOG_BITMASK": (176126, I32), "ESC_CALIBRATION": (0, I8),
    "TUNE": (0, I8), "TUNE_MIN": (0, F), "TUNE_MAX": (0, F), "FRAME_CLASS": (0, I8),
    "FRAME_TYPE": (1, I8), "DISARM_DELAY": (10, I8), "ANGLE_MAX": (3000, I16),
    "PHLD_BRAKE_RATE": (8, I16), "PHLD_BRAKE_ANGLE": (3000, I16), "RC_SPEED": (490, I16),
    "ACRO_RP_RATE": (360, F), "ACRO_YAW_RATE": (202.5, F), "ACRO_RP_EXPO": (0.3, F),
    "ACRO_Y_EXPO": (0, F), "ACRO_THR_MID": (0, F), "ACRO_BAL_ROLL": (1, F),
    "ACRO_BAL_PITCH": (1, F), "ACRO_TRAINER": (2, I8), "ACRO_OPTIONS": (0, I8),
    "THROW_MOT_START": (0, I8), "THROW_NEXTMODE": (18, I8), "THROW_TYPE": (0, I8),
    "TERRAIN_FOLLOW": (0, I8), "GND_EFFECT_COMP": (1, I8), "DEV_OPTIONS": (0, I32),
    "GUID_OPTIONS": (0, I32), "GUID_TIMEOUT": (3, F), "TKOFF_SLEW_TIME": (2, F),
    "TKOFF_RPM_MIN": (0, F), "SURFTRAK_MODE": (1, I8), "CHUTE_ENABLED": (0, I8),
    "AUTOTUNE_AXES": (7, I8), "AUTOTUNE_AGGR": (0.1, F), "AUTOTUNE_MIN_D": (0.001, F),
    "SRTL_ACCURACY": (2, F), "SRTL_POINTS": (300, I16), "SRTL_OPTIONS": (0, I32),
}  # fmt: skip

_ARMING_AND_BATTERY: dict[str, tuple[float, int]] = {
    "ARMING_CHECK": (1, I32), "ARMING_RUDDER": (2, I8), "ARMING_ACCTHRESH": (0.75, F),
    "ARMING_MIS_ITEMS": (0, I32), "ARMING_OPTIONS": (0, I32), "ARMING_MAGTHRESH": (100, I16),
    "BATT_MONITOR": (0, I8), "BATT_CAPACITY": (3300, I32), "BATT_SERIAL_NUM": (-1, I32),
    "BATT_LOW_TIMER": (10, I8), "BATT_FS_VOLTSRC": (0, I8), "BATT_LOW_VOLT": (10.5, F),
    "BATT_LOW_MAH": (0, F), "BATT_CRT_VOLT": (0, F), "BATT_CRT_MAH": (0, F),
    "BATT_FS_LOW_ACT": (0, I8), "BATT_FS_CRT_ACT": (0, I8), "BATT_ARM_VOLT": (0, F),
    "BATT_ARM_MAH": (0, I32), "BATT_OPTIONS": (0, I32), "BATT_VOLT_PIN": (13, I8),
    "BATT_CURR_PIN": (12, I8), "BATT_VOLT_MULT": (10.1, F), "BATT_AMP_PERVLT": (17, F),
    "BATT_AMP_OFFSET": (0, F), "BATT_VLT_OFFSET": (0, F), "BATT2_MONITOR": (0, I8),
    "FENCE_ENABLE": (0, I8), "FENCE_TYPE": (7, I8), "FENCE_ACTION": (1, I8),
    "FENCE_ALT_MAX": (100, F), "FENCE_ALT_MIN": (-10, F), "FENCE_RADIUS": (300, F),
    "FENCE_MARGIN": (2, F), "FENCE_TOTAL": (0, I8), "RALLY_TOTAL": (0, I8),
    "RALLY_LIMIT_KM": (0.3, F), "RALLY_INCL_HOME": (1, I8), "MIS_TOTAL": (0, I16),
    "MIS_RESTART": (0, I8), "MIS_OPTIONS": (0, I16),
}  # fmt: skip

_NAVIGATION: dict[str, tuple[float, int]] = {
    "WPNAV_SPEED": (1000, F), "WPNAV_RADIUS": (200, F), "WPNAV_SPEED_UP": (250, F),
    "WPNAV_SPEED_DN": (150, F), "WPNAV_ACCEL": (250, F), "WPNAV_ACCEL_Z": (100, F),
    "WPNAV_ACCEL_C": (0, F), "WPNAV_RFND_USE": (1, I8), "WPNAV_JERK": (1, F),
    "WPNAV_TER_MARGIN": (10, F), "LOIT_ANG_MAX": (0, F), "LOIT_SPEED": (1250, F),
    "LOIT_ACC_MAX": (500, F), "LOIT_BRK_ACCEL": (250, F), "LOIT_BRK_JERK": (500, F),
    "LOIT_BRK_DELAY": (1, F), "CIRCLE_RADIUS": (1000, F), "CIRCLE_RATE": (20, F),
    "CIRCLE_OPTIONS": (1, I16), "AVOID_ENABLE": (3, I8), "AVOID_ANGLE_MAX": (1000, I16),
    "AVOID_DIST_MAX": (5, F), "AVOID_MARGIN": (2, F), "AVOID_BEHAVE": (0, I8),
    "AVOID_BACKUP_SPD": (0.75, F), "AVOID_ALT_MIN": (0, F), "AVOID_ACCEL_MAX": (3, F),
    "AVOID_BACKUP_DZ": (0.1, F), "TERRAIN_ENABLE": (1, I8), "TERRAIN_SPACING": (100, I16),
    "TERRAIN_OPTIONS": (0, I16), "TERRAIN_MARGIN": (0.05, F), "TERRAIN_OFS_MAX": (30, F),
    "PSC_POSZ_P": (1, F), "PSC_VELZ_P": (5, F), "PSC_VELZ_I": (0, F), "PSC_VELZ_IMAX": (1000, F),
    "PSC_VELZ_FLTE": (5, F), "PSC_VELZ_FF": (0, F), "PSC_ACCZ_P": (0.5, F),
    "PSC_ACCZ_I": (1, F), "PSC_ACCZ_D": (0, F), "PSC_ACCZ_IMAX": (800, F),
    "PSC_ACCZ_FF": (0, F), "PSC_ACCZ_FLTT": (0, F), "PSC_ACCZ_FLTE": (20, F),
    "PSC_ACCZ_FLTD": (0, F), "PSC_ACCZ_SMAX": (0, F), "PSC_POSXY_P": (1, F),
    "PSC_VELXY_P": (2, F), "PSC_VELXY_I": (1, F), "PSC_VELXY_D": (0.5, F),
    "PSC_VELXY_IMAX": (1000, F), "PSC_VELXY_FLTE": (5, F), "PSC_VELXY_FLTD": (5, F),
    "PSC_VELXY_FF": (0, F), "PSC_ANGLE_MAX": (0, F), "PSC_JERK_XY": (5, F), "PSC_JERK_Z": (5, F),
}  # fmt: skip

_ATTITUDE_AND_MOTORS: dict[str, tuple[float, int]] = {
    "ATC_SLEW_YAW": (6000, F), "ATC_ACCEL_Y_MAX": (27000, F), "ATC_RATE_FF_ENAB": (1, I8),
    "ATC_ACCEL_R_MAX": (110000, F), "ATC_ACCEL_P_MAX": (110000, F), "ATC_ANGLE_BOOST": (1, I8),
    "ATC_ANG_RLL_P": (4.5, F), "ATC_ANG_PIT_P": (4.5, F), "ATC_ANG_YAW_P": (4.5, F),
    "ATC_ANG_LIM_TC": (1, F), "ATC_RATE_R_MAX": (0, F), "ATC_RATE_P_MAX": (0, F),
    "ATC_RATE_Y_MAX": (0, F), "ATC_INPUT_TC": (0.15, F), "ATC_THR_MIX_MIN": (0.1, F),
    "ATC_THR_MIX_MAX": (0.5, F), "ATC_THR_MIX_MAN": (0.1, F), "ATC_THR_G_BOOST": (0, F),
    "MOT_YAW_HEADROOM": (200, I16), "MOT_THST_EXPO": (0.65, F), "MOT_SPIN_MAX": (0.95, F),
    "MOT_BAT_VOLT_MAX": (0, F), "MOT_BAT_VOLT_MIN": (0, F), "MOT_BAT_CURR_MAX": (0, F),
    "MOT_BAT_CURR_TC": (5, F), "MOT_BAT_IDX": (0, I8), "MOT_PWM_TYPE": (0, I8),
    "MOT_PWM_MIN": (1000, I16), "MOT_PWM_MAX": (2000, I16), "MOT_SPIN_MIN": (0.15, F),
    "MOT_SPIN_ARM": (0.1, F), "MOT_THST_HOVER": (0.35, F), "MOT_HOVER_LEARN": (2, I8),
    "MOT_SAFE_DISARM": (0, I8), "MOT_YAW_SV_ANGLE": (30, F), "MOT_SPOOL_TIME": (0.5, F),
    "MOT_SPOOL_TIM_DN": (0, F), "MOT_BOOST_SCALE": (0, F), "MOT_SLEW_UP_TIME": (0, F),
    "MOT_SLEW_DN_TIME": (0, F), "MOT_SAFE_TIME": (1, F), "MOT_OPTIONS": (0, I16),
}  # fmt: skip
for _axis, (_p, _i, _d, _flte, _fltd) in {
    "RLL": (0.135, 0.135, 0.0036, 0, 20), "PIT": (0.135, 0.135, 0.0036, 0, 20),
    "YAW": (0.18, 0.018, 0, 2.5, 0),
}.items():  # fmt: skip
    _ATTITUDE_AND_MOTORS.update({
        f"ATC_RAT_{_axis}_P": (_p, F), f"ATC_RAT_{_axis}_I": (_i, F),
        f"ATC_RAT_{_axis}_D": (_d, F), f"ATC_RAT_{_axis}_IMAX": (0.5, F),
        f"ATC_RAT_{_axis}_FF": (0, F), f"ATC_RAT_{_axis}_FLTT": (20, F),
        f"ATC_RAT_{_axis}_FLTE": (_flte, F), f"ATC_RAT_{_axis}_FLTD": (_fltd, F),
        f"ATC_RAT_{_axis}_SMAX": (0, F),
    })  # fmt: skip

_SENSORS: dict[str, tuple[float, int]] = {
    "AHRS_GPS_GAIN": (1, F), "AHRS_GPS_USE": (1, I8), "AHRS_YAW_P": (0.2, F),
    "AHRS_RP_P": (0.2, F), "AHRS_WIND_MAX": (0, I8), "AHRS_TRIM_X": (0, F),
    "AHRS_TRIM_Y": (0, F), "AHRS_TRIM_Z": (0, F), "AHRS_ORIENTATION": (0, I8),
    "AHRS_COMP_BETA": (0.1, F), "AHRS_GPS_MINSATS": (6, I8), "AHRS_EKF_TYPE": (3, I8),
    "AHRS_OPTIONS": (0, I16), "INS_GYRO_FILTER": (20, I16), "INS_ACCEL_FILTER": (20, I16),
    "INS_USE": (1, I8), "INS_USE2": (1, I8), "INS_USE3": (1, I8), "INS_STILL_THRESH": (2.5, F),
    "INS_GYR_CAL": (1, I8), "INS_TRIM_OPTION": (1, I8), "INS_ACC_BODYFIX": (2, I8),
    "INS_FAST_SAMPLE": (1, I8), "INS_ENABLE_MASK": (127, I8), "INS_GYRO_RATE": (0, I8),
    "INS_TCAL_OPTIONS": (0, I32), "INS_HNTCH_ENABLE": (0, I8), "INS_HNTC2_ENABLE": (0, I8),
    "INS_LOG_BAT_MASK": (0, I8), "INS_RAW_LOG_OPT": (0, I16),
    "COMPASS_DEC": (0, F), "COMPASS_LEARN": (0, I8), "COMPASS_USE": (1, I8),
    "COMPASS_USE2": (1, I8), "COMPASS_USE3": (1, I8), "COMPASS_AUTODEC": (1, I8),
    "COMPASS_MOTCT": (0, I8), "COMPASS_ORIENT": (0, I8), "COMPASS_EXTERNAL": (0, I8),
    "COMPASS_CAL_FIT": (16, F), "COMPASS_OFFS_MAX": (1800, I16), "COMPASS_TYPEMASK": (0, I32),
    "COMPASS_FLTR_RNG": (0, I8), "COMPASS_AUTO_ROT": (2, I8), "COMPASS_ENABLE": (1, I8),
    "COMPASS_SCALE": (0, F), "COMPASS_OPTIONS": (0, I16), "COMPASS_DEV_ID": (0, I32),
    "COMPASS_PRIO1_ID": (0, I32), "GPS_TYPE": (1, I8), "GPS_TYPE2": (0, I8),
    "GPS_NAVFILTER": (8, I8), "GPS_AUTO_SWITCH": (1, I8), "GPS_MIN_DGPS": (100, I8),
    "GPS_SBAS_MODE": (2, I8), "GPS_MIN_ELEV": (-100, I8), "GPS_INJECT_TO": (127, I8),
    "GPS_RAW_DATA": (0, I8), "GPS_GNSS_MODE": (0, I8), "GPS_SAVE_CFG": (2, I8),
    "GPS_AUTO_CONFIG": (1, I8), "GPS_RATE_MS": (200, I16), "GPS_DELAY_MS": (0, I16),
    "GPS_BLEND_MASK": (5, I8), "GPS_DRV_OPTIONS": (0, I16), "GPS_PRIMARY": (0, I8),
    "BARO_GND_TEMP": (0, F), "BARO_ALT_OFFSET": (0, F), "BARO_PRIMARY": (0, I8),
    "BARO_EXT_BUS": (-1, I8), "BARO_FLTR_RNG": (0, I8), "BARO_PROBE_EXT": (0, I32),
    "BARO_OPTIONS": (0, I8), "BARO1_GND_PRESS": (0, F), "RNGFND1_TYPE": (0, I8),
    "PRX1_TYPE": (0, I8), "FLOW_TYPE": (0, I8), "CAM1_TYPE": (0, I8), "MNT1_TYPE": (0, I8),
    "RPM1_TYPE": (0, I8), "GRIP_ENABLE": (0, I8), "PLND_ENABLED": (0, I8), "ADSB_TYPE": (0, I8),
    "OA_TYPE": (0, I8), "FOLL_ENABLE": (0, I8), "RSSI_TYPE": (0, I8), "OSD_TYPE": (0, I8),
    "VISO_TYPE": (0, I8), "BCN_TYPE": (0, I8), "EAHRS_TYPE": (0, I8), "SCR_ENABLE": (0, I8),
}  # fmt: skip
for _axis in "XYZ":
    _SENSORS.update({
        f"INS_GYROFFS_{_axis}": (0, F), f"INS_GYR2OFFS_{_axis}": (0, F),
        f"INS_ACCOFFS_{_axis}": (0, F), f"INS_ACC2OFFS_{_axis}": (0, F),
        f"INS_ACCSCAL_{_axis}": (1, F), f"INS_ACC2SCAL_{_axis}": (1, F),
        f"INS_POS1_{_axis}": (0, F), f"COMPASS_OFS_{_axis}": (0, F),
        f"COMPASS_OFS2_{_axis}": (0, F), f"COMPASS_MOT_{_axis}": (0, F),
        f"COMPASS_DIA_{_axis}": (1, F), f"COMPASS_ODI_{_axis}": (0, F),
        f"GPS_POS1_{_axis}": (0, F),
    })  # fmt: skip

_EKF3: dict[str, tuple[float, int]] = {
    "EK3_ENABLE": (1, I8), "EK3_VELNE_M_NSE": (0.3, F), "EK3_VELD_M_NSE": (0.5, F),
    "EK3_VEL_I_GATE": (500, I16), "EK3_POSNE_M_NSE": (0.5, F), "EK3_POS_I_GATE": (500, I16),
    "EK3_GLITCH_RAD": (25, I16), "EK3_ALT_M_NSE": (2, F), "EK3_HGT_I_GATE": (500, I16),
    "EK3_HGT_DELAY": (60, I16), "EK3_MAG_M_NSE": (0.05, F), "EK3_MAG_CAL": (3, I8),
    "EK3_MAG_I_GATE": (300, I16), "EK3_EAS_M_NSE": (1.4, F), "EK3_EAS_I_GATE": (400, I16),
    "EK3_RNG_M_NSE": (0.5, F), "EK3_RNG_I_GATE": (500, I16), "EK3_MAX_FLOW": (2.5, F),
    "EK3_FLOW_M_NSE": (0.25, F), "EK3_FLOW_I_GATE": (300, I16), "EK3_FLOW_DELAY": (10, I8),
    "EK3_GYRO_P_NSE": (0.015, F), "EK3_ACC_P_NSE": (0.35, F), "EK3_GBIAS_P_NSE": (0.001, F),
    "EK3_ABIAS_P_NSE": (0.02, F), "EK3_WIND_P_NSE": (0.2, F), "EK3_WIND_PSCALE": (1, F),
    "EK3_GPS_CHECK": (31, I8), "EK3_IMU_MASK": (3, I8), "EK3_CHECK_SCALE": (100, I16),
    "EK3_NOAID_M_NSE": (10, F), "EK3_BETA_MASK": (0, I8), "EK3_YAW_M_NSE": (0.5, F),
    "EK3_YAW_I_GATE": (300, I16), "EK3_TAU_OUTPUT": (25, I8), "EK3_MAGE_P_NSE": (0.001, F),
    "EK3_MAGB_P_NSE": (0.0001, F), "EK3_RNG_USE_HGT": (-1, I8), "EK3_TERR_GRAD": (0.1, F),
    "EK3_RNG_USE_SPD": (2, F), "EK3_ACC_BIAS_LIM": (1, F), "EK3_MAG_MASK": (0, I8),
    "EK3_OGN_HGT_MASK": (0, I8), "EK3_VIS_VERR_MIN": (0.1, F), "EK3_VIS_VERR_MAX": (0.9, F),
    "EK3_WENC_VERR": (0.1, F), "EK3_FLOW_USE": (1, I8), "EK3_HRT_FILT": (2, F),
    "EK3_MAG_EF_LIM": (50, I16), "EK3_GSF_RUN_MASK": (3, I8), "EK3_GSF_USE_MASK": (3, I8),
    "EK3_GSF_RST_MAX": (2, I8), "EK3_ERR_THRESH": (0.2, F), "EK3_AFFINITY": (0, I32),
    "EK3_DRAG_BCOEF_X": (0, F), "EK3_DRAG_BCOEF_Y": (0, F), "EK3_DRAG_M_NSE": (0.5, F),
    "EK3_DRAG_MCOEF": (0, F), "EK3_OGNM_TEST_SF": (2, F), "EK3_GND_EFF_DZ": (4, F),
    "EK3_PRIMARY": (0, I8), "EK3_LOG_LEVEL": (0, I8), "EK3_GPS_VACC_MAX": (0, F),
    "EK3_OPTIONS": (0, I32), "EK3_SRC1_POSXY": (3, I8), "EK3_SRC1_VELXY": (3, I8),
    "EK3_SRC1_POSZ": (1, I8), "EK3_SRC1_VELZ": (3, I8), "EK3_SRC1_YAW": (1, I8),
    "EK3_SRC2_POSXY": (0, I8), "EK3_SRC2_VELXY": (0, I8), "EK3_SRC2_POSZ": (1, I8),
    "EK3_SRC2_VELZ": (0, I8), "EK3_SRC2_YAW": (0, I8), "EK3_SRC_OPTIONS": (1, I16),
}  # fmt: skip

_BOARD_AND_LINKS: dict[str, tuple[float, int]] = {
    "BRD_SAFETY_DEFLT": (1, I8), "BRD_SAFETYOPTION": (3, I16), "BRD_SER1_RTSCTS": (2, I8),
    "BRD_IO_ENABLE": (1, I8), "BRD_BOOT_DELAY": (0, I16), "BRD_OPTIONS": (1, I32),
    "BRD_RTC_TYPES": (1, I8), "BRD_RTC_TZ_MIN": (0, I16), "BRD_VBUS_MIN": (4.3, F),
    "BRD_VSERVO_MIN": (0, F), "BRD_HEAT_TARG": (-1, I8), "BRD_SD_SLOWDOWN": (0, I8),
    "BRD_SAFETY_MASK": (0, I32), "SCHED_DEBUG": (0, I8), "SCHED_LOOP_RATE": (400, I16),
    "SCHED_OPTIONS": (0, I8), "STAT_BOOTCNT": (0, I16), "STAT_FLTTIME": (0, I32),
    "STAT_RUNTIME": (0, I32), "STAT_RESET": (1, I32), "LOG_BACKEND_TYPE": (1, I8),
    "LOG_FILE_BUFSIZE": (200, I16), "LOG_DISARMED": (0, I8), "LOG_REPLAY": (0, I8),
    "LOG_FILE_DSRMROT": (0, I8), "LOG_MAV_BUFSIZE": (8, I8), "LOG_FILE_TIMEOUT": (5, I16),
    "LOG_FILE_MB_FREE": (500, I16), "LOG_FILE_RATEMAX": (0, F), "LOG_MAV_RATEMAX": (0, F),
    "LOG_BLK_RATEMAX": (0, F), "NTF_LED_BRIGHT": (3, I8), "NTF_LED_OVERRIDE": (0, I8),
    "NTF_DISPLAY_TYPE": (0, I8), "NTF_BUZZ_VOLUME": (100, I8), "CAN_P1_DRIVER": (0, I8),
    "CAN_P2_DRIVER": (0, I8), "RCMAP_ROLL": (1, I8), "RCMAP_PITCH": (2, I8),
    "RCMAP_THROTTLE": (3, I8), "RCMAP_YAW": (4, I8), "RC_OVERRIDE_TIME": (3, F),
    "RC_OPTIONS": (32, I32), "RC_PROTOCOLS": (1, I32), "RC_FS_TIMEOUT": (1, F),
    "SERVO_RATE": (50, I16), "SERVO_DSHOT_RATE": (0, I8), "SERVO_DSHOT_ESC": (0, I8),
    "SERIAL_PASS1": (0, I8), "SERIAL_PASS2": (-1, I8), "SERIAL_PASSTIMO": (15, I8),
    "SERIAL0_BAUD": (115, I32), "SERIAL0_PROTOCOL": (2, I8),
}  # fmt: skip
for _n, (_protocol, _baud) in enumerate(
    [(2, 57), (2, 57), (5, 38), (5, 38), (-1, 57), (-1, 57), (-1, 57)], start=1
):
    _BOARD_AND_LINKS.update({
        f"SERIAL{_n}_PROTOCOL": (_protocol, I8), f"SERIAL{_n}_BAUD": (_baud, I32),
        f"SERIAL{_n}_OPTIONS": (0, I16),
    })  # fmt: skip
for _n in range(4):  # one SRn_ group per MAVLink channel: stream rates in Hz, 0 by default
    for _stream in (
        "RAW_SENS", "EXT_STAT", "RC_CHAN", "RAW_CTRL", "POSITION", "EXTRA1", "EXTRA2", "EXTRA3",
        "PARAMS", "ADSB",
    ):  # fmt: skip
        _BOARD_AND_LINKS[f"SR{_n}_{_stream}"] = (0, I16)
for _n in range(1, 17):
    _BOARD_AND_LINKS.update({
        f"RC{_n}_MIN": (1100, I16), f"RC{_n}_TRIM": (1500, I16), f"RC{_n}_MAX": (1900, I16),
        f"RC{_n}_REVERSED": (0, I8), f"RC{_n}_DZ": (0, I16), f"RC{_n}_OPTION": (0, I16),
    })  # fmt: skip
for _n in range(1, 17):
    _BOARD_AND_LINKS.update({
        f"SERVO{_n}_MIN": (1100, I16), f"SERVO{_n}_MAX": (1900, I16),
        f"SERVO{_n}_TRIM": (1500, I16), f"SERVO{_n}_REVERSED": (0, I8),
        f"SERVO{_n}_FUNCTION": (0, I16),
    })  # fmt: skip

#: Every parameter, in the order PARAM_REQUEST_LIST sends them (ArduPilot's is by storage key;
#: ground stations index by name), with ArduPilot Copter 4.5's defaults.
DEFAULTS: dict[str, tuple[float, int]] = dict(
    sorted({**_COPTER, **_ARMING_AND_BATTERY, **_NAVIGATION, **_ATTITUDE_AND_MOTORS,
            **_SENSORS, **_EKF3, **_BOARD_AND_LINKS}.items())
)  # fmt: skip

#: The simulated vehicle's setup where it differs from the defaults (what its owner configured).
SIM_CONFIG: dict[str, float] = {
    "FRAME_CLASS": 1,  # quad
    "FRAME_TYPE": 1,  # X
    "BATT_MONITOR": 4,  # analog voltage and current
    "BATT_CAPACITY": 5500,  # mAh: the simulated battery
    "BATT_LOW_MAH": 275,  # 5 % left: the simulated battery's failsafe ...
    "BATT_FS_LOW_ACT": 1,  # ... lands
    "WPNAV_SPEED_UP": 200,  # cm/s: the seed's 2 m/s climb
    "BRD_SAFETY_DEFLT": 0,  # no safety switch
    "SERVO1_FUNCTION": 33, "SERVO2_FUNCTION": 34,  # motors 1..4, as FRAME_CLASS 1 sets them
    "SERVO3_FUNCTION": 35, "SERVO4_FUNCTION": 36,
}  # fmt: skip
