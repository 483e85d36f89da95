"""How the simulated multirotor is oriented (sim/vehicle.py): it tilts as much as its
acceleration and the drag of the air it moves through need, and points its nose along its track.

No attitude controller is simulated: the attitude is read off the motion the vehicle flies, which
is what a quad's attitude loop settles to within a fraction of a second.
"""

from __future__ import annotations

import math

from dronefleet.sim.wind import Wind
from dronefleet.vehicle.base import Attitude
from dronefleet.vehicle.kinematics import GRAVITY_MPS2, Kinematics

#: Tilt needed to hold airspeed against drag, per m/s of airspeed (≈20° at 10 m/s).
DRAG_ACCEL_PER_MPS = 0.36
#: Below this ground speed the heading (yaw) is kept rather than taken from the track.
MIN_TRACK_SPEED_MPS = 0.5


def track_yaw(k: Kinematics, yaw_deg: float) -> float:
    """The heading after a step: along the track when moving, else as it was."""
    if k.vn * k.vn + k.ve * k.ve > MIN_TRACK_SPEED_MPS * MIN_TRACK_SPEED_MPS:
        return math.degrees(math.atan2(k.ve, k.vn)) % 360.0
    return yaw_deg


def attitude(k: Kinematics, yaw_deg: float, wind: Wind, thrusting: bool) -> Attitude:
    """Roll and pitch for the acceleration plus drag (level when the motors do not hold it up:
    on the ground or falling); yaw as given."""
    if not thrusting:
        return Attitude(0.0, 0.0, yaw_deg)
    yaw = math.radians(yaw_deg)
    an = k.an + DRAG_ACCEL_PER_MPS * (k.vn - wind.n_mps)
    ae = k.ae + DRAG_ACCEL_PER_MPS * (k.ve - wind.e_mps)
    forward = an * math.cos(yaw) + ae * math.sin(yaw)
    right = -an * math.sin(yaw) + ae * math.cos(yaw)
    lift = GRAVITY_MPS2 - k.ad
    return Attitude(
        roll_deg=math.degrees(math.atan2(right, lift)),
        pitch_deg=-math.degrees(math.atan2(forward, lift)),
        yaw_deg=yaw_deg,
    )
