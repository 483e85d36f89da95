"""A chaos schedule: the faults, drawn from a seed alone."""

from __future__ import annotations

import random
from dataclasses import dataclass

#: Every fault the suite draws from. ``*.kill``: SIGKILL, started again after the fault's
#: duration (a drone sometimes never); ``*.stop``: SIGSTOP, then SIGCONT.
KINDS = (
    "ground.kill",
    "ground.stop",
    "drone.kill",
    "drone.stop",
    "drone_broker.kill",
    "drone_broker.stop",
    "ground_broker.kill",
    "ground_broker.stop",
    "link.latency",
    "link.loss",
    "link.partition",
    "disk.full",
)
#: Faults aimed at one drone (its process, its broker or its link).
PER_DRONE = ("drone.", "drone_broker.", "link.")
DRONES = 3
HOME = (40.63, -8.659, 10.0)
#: Metres north of the homes where the area starts, its size (east x north) and spacing.
AREA_NORTH_M, AREA_EAST_M, AREA_N_M, AREA_SPACING_M = 20.0, 60.0, 40.0, 10.0
#: The homes, 12 m apart along the east.
HOME_STEP_E_M = 12.0
#: Vehicle seconds the mission takes without faults, to place the faults within it (measured
#: with ``bench/chaos.py --baseline``: 69 s at 1x, 14 s wall at 5x).
MISSION_VEHICLE_S = 75.0
FAULTS = (1, 3)
DURATION_S = (2.0, 30.0)
FOR_GOOD_P = 0.3
SEPARATION_H_M, SEPARATION_V_M = 5.0, 3.0


@dataclass(frozen=True)
class Fault:
    kind: str
    at_s: float  # wall seconds after the mission was started
    duration_s: float
    drone: int | None = None  # index of the drone it hits (per-drone faults)
    for_good: bool = False  # a drone killed and never started again
    level: float = 0.0  # link.latency: seconds each way; link.loss: the loss probability

    def label(self, drones: list[str] | None = None) -> str:
        who = ""
        if self.drone is not None:
            who = f"[{drones[self.drone] if drones else f'd{self.drone}'}]"
        what = f"{self.kind}{who}@{self.at_s:.0f}s"
        if self.for_good:
            return what + "/forever"
        extra = ""
        if self.kind == "link.latency":
            extra = f",{self.level * 1000:.0f}ms"
        elif self.kind == "link.loss":
            extra = f",{self.level:.0%}"
        return f"{what}+{self.duration_s:.0f}s{extra}"


@dataclass(frozen=True)
class Schedule:
    seed: int
    speedup: float
    busy: int  # busy-loop processes beside the fleet
    faults: tuple[Fault, ...]

    def label(self) -> str:
        return " ".join(f.label() for f in self.faults) or "none"


def mission_wall_s(speedup: float) -> float:
    return MISSION_VEHICLE_S / speedup


def draw(
    seed: int,
    *,
    speedups: tuple[float, ...] = (1.0, 5.0),
    busy: tuple[int, ...] = (0, 2),
    kinds: tuple[str, ...] = KINDS,
    faults: tuple[int, int] = FAULTS,
) -> Schedule:
    """The schedule of ``seed``: its speed-up, busy loops and 1-3 faults (kind, start within the
    mission's expected wall time, duration 2-30 s, target drone, for good or not)."""
    rng = random.Random(seed)
    speedup = rng.choice(speedups)
    loops = rng.choice(busy)
    span = mission_wall_s(speedup)
    drawn = []
    for _ in range(rng.randint(*faults)):
        kind = rng.choice(kinds)
        at_s = round(rng.uniform(0.05, 0.7) * span, 1)
        duration_s = round(rng.uniform(*DURATION_S), 1)
        drone = rng.randrange(DRONES) if kind.startswith(PER_DRONE) else None
        for_good = kind == "drone.kill" and rng.random() < FOR_GOOD_P
        level = 0.0
        if kind == "link.latency":
            level = round(rng.uniform(0.2, 1.5), 2)
        elif kind == "link.loss":
            level = round(rng.uniform(0.1, 0.4), 2)
        drawn.append(Fault(kind, at_s, duration_s, drone, for_good, level))
    drawn.sort(key=lambda f: f.at_s)
    return Schedule(seed, speedup, loops, tuple(drawn))
