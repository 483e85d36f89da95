"""Chaos (issue 26, item 8): five fixed fault schedules over the real bridged topology.

Each is a row of ``bench/chaos.py`` (tests/support/chaos/): three ``dronefleet drone --fc sim``
processes at 5x, each with its own Mosquitto bridged to the ground's through a TCP proxy,
``dronefleet ground``, an area for the three posted over REST, and the seed's faults while it is
flown. Then: every report a drone sent is in the planner's record, no waypoint flown twice, the
mission completed (ended_at set) when some drone was left to finish it, nobody sent home without
a cause, no two drones within 5 m.

The seeds, and what they draw (``bench/chaos.py --seed N --schedules 1 --speedup 5 --dry-run``):

- 104: a drone killed and started again 20 s later, another stopped 2 s, the ground killed 5 s;
- 108: the ground stopped 7 s, the ground broker killed 13 s, the ground's disk full 7 s;
- 114: a drone killed for good, another's link partitioned 20 s;
- 125: a drone's link lossy (31 %), another drone killed 21 s, the first one's broker killed 7 s;
- 133: two busy loops beside it; a drone's link slow (1.17 s each way) 23 s, another drone's
  broker stopped 25 s.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from support import chaos
from support.brokers import MOSQUITTO

pytestmark = pytest.mark.integration

#: Seeds 108, 114 and 133 were expected failures until issue 26's last causes were fixed (a
#: mission settled while a refill was outstanding; a killed drone's replacement refused for its
#: keep-out; reports dropped after a mission's end): each passes now (docs/resilience.md).
SEEDS = (104, 108, 114, 125, 133)
#: A failed run's logs are kept here (pytest's own temporary folders are soon reused).
KEPT = Path(__file__).resolve().parents[2] / "test-artifacts" / "chaos"


# About 1.5 min each on an idle machine; a machine loaded by other work starts the processes slowly.
@pytest.mark.timeout(600)
@pytest.mark.parametrize("seed", SEEDS)
def test_a_drawn_fault_schedule_keeps_every_report_waypoint_and_drone(seed: int, tmp_path: Path):
    if not Path(MOSQUITTO).exists():
        pytest.fail(
            "mosquitto is not installed: run `make system-deps` (apt-get install mosquitto)"
        )
    schedule = chaos.draw(seed, speedups=(5.0,))
    outcome = chaos.run(schedule, tmp_path)
    print(chaos.table([outcome]))
    if outcome.failed:
        kept = KEPT / f"seed-{seed}"
        shutil.rmtree(kept, ignore_errors=True)
        shutil.copytree(tmp_path, kept, symlinks=True, ignore_dangling_symlinks=True)
        outcome.folder = str(kept)
    assert not outcome.failed, f"{chaos.table([outcome])}\n{chaos.failures([outcome])}"
