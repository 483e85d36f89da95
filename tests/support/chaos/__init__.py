"""Chaos over the seed's real topology (issue 26, item 8): drawn fault schedules, flown and checked.

The topology is tests/integration/planner/test_faults_real_topology.py's, with three drones: a
ground Mosquitto; per drone a Mosquitto bridged to it with the configuration ``dronefleet
bridge-config`` writes, its bridge going through a :class:`ChaosLink` (a TCP proxy whose latency,
loss and partitions change while it runs), and ``dronefleet drone --fc sim --state-dir
--log-dir``; ``dronefleet ground`` with its state (and telemetry) on a tmpfs of its own when run
as root, so the disk can be filled. An area (60 x 40 m at 10 m spacing) is posted over REST for
the three drones and, while it is flown, the schedule's faults come and go: SIGKILL (then a
restart, or for good for a drone) and SIGSTOP (then SIGCONT) of the ground, a drone process, a
drone's broker or the ground broker; latency, loss and a partition on a drone's link; the
ground's disk full. Optionally two busy loops (``python -c "while True: pass"``) share the CPU.

A schedule is drawn from its seed alone (:func:`draw`): the same seed, the same faults at the
same times; what the software makes of them may differ from run to run.

After each run (:func:`run`) the checks, each ``ok``, a failure with what failed, or ``n/a``:

- ``reports``: every report a drone sent (its own ``reports.db``, and for a drone killed for good
  the reports its logger saw reach its broker) is in the planner's record (``legs[].seqs``);
  reports of legs that ended the drone's part (recovery legs) and arrived after the mission
  ended are counted apart (``late``).
- ``once``: no waypoint (a ``wait_for_flight`` work step) was reached by two drones, or twice,
  by what the drones themselves reported; and, the mission completed, every one was reached.
- ``ended``: the mission ``completed`` with ``ended_at`` set, whenever some drone was left to
  finish it (else n/a: it may fail or stall).
- ``home``: no drone was sent home (a recovery leg: RTL) without a cause: it was replaced
  after a fault of its own (its process, its broker, its link) or a CRITICAL alarm, or it was
  a replacement whose takeover was called off.
- ``apart``: no two drones in the air were within 5 m horizontally and 3 m vertically at once
  (the README's rule), by the positions each drone's own log recorded (5 Hz of vehicle time).
"""

from support.chaos.run import CHECKS, Outcome, run
from support.chaos.schedule import KINDS, Fault, Schedule, draw
from support.chaos.table import failures, short, table

__all__ = [
    "CHECKS",
    "KINDS",
    "Fault",
    "Outcome",
    "Schedule",
    "draw",
    "failures",
    "run",
    "short",
    "table",
]
