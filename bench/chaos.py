"""Chaos suite (issue 26, item 8): drawn fault schedules over the real bridged topology, checked.

Each schedule (tests/support/chaos/) starts a ground Mosquitto, three drones (``dronefleet
drone --fc sim``, each with its own Mosquitto bridged to the ground's through a TCP proxy),
``dronefleet ground`` (its state on a tmpfs when run as root), posts a 60 x 40 m area at 10 m
spacing for the three over REST, and makes 1-3 faults at random times while it is flown: SIGKILL
(then a restart, or a drone for good) or SIGSTOP of the ground, a drone, a drone's broker or the
ground broker; latency, loss or a partition on a drone's link; the ground's disk full; each for
2-30 s. Speed-up 1x or 5x, with or without two busy loops beside it. Then it checks that every
report a drone sent is in the planner's record, no waypoint was flown twice, the mission
completed (ended_at set) when some drone was left to finish it, no drone was sent home without a
cause, and no two drones came within 5 m; and prints a table.

Schedule i has seed ``--seed + i``: a row is run again alone with ``--seed SEED --schedules 1``.
The schedule is the seed's; the outcome may vary from run to run.

    .venv/bin/python bench/chaos.py --seed 1 --schedules 10 [--speedup 1 5] [--busy 0 2]
        [--kinds drone.kill link.partition ...] [--out DIR] [--baseline]

Each run keeps its logs in ``--out`` (default: a temporary folder, printed), with
``outcome.json``; failed checks are listed under the table with the run's events.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from support import chaos


def main() -> int:
    # Stopped (Ctrl-C, or TERM; a background job's SIGINT is ignored), the run in progress still
    # stops its processes and unmounts its tmpfs on the way out.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--seed", type=int, default=1, help="the first schedule's seed")
    p.add_argument("--schedules", type=int, default=10, help="how many schedules to run")
    p.add_argument("--speedup", type=float, nargs="+", default=[1.0, 5.0], help="drawn from")
    p.add_argument("--busy", type=int, nargs="+", default=[0, 2], help="busy loops, drawn from")
    p.add_argument("--kinds", nargs="+", default=list(chaos.KINDS), choices=chaos.KINDS)
    p.add_argument("--out", type=Path, help="folder for each run's logs (default: a temp one)")
    p.add_argument("--baseline", action="store_true", help="one run without faults (its wall time)")
    p.add_argument("--dry-run", action="store_true", help="print the schedules only")
    args = p.parse_args()
    schedules = [
        chaos.draw(
            args.seed + i,
            speedups=tuple(args.speedup),
            busy=tuple(args.busy),
            kinds=tuple(args.kinds),
        )
        for i in range(args.schedules)
    ]
    if args.baseline:
        schedules = [chaos.Schedule(args.seed, args.speedup[0], args.busy[0], ())]
    if args.dry_run:
        for s in schedules:
            print(f"{s.seed:>6}  x{s.speedup:g}  busy {s.busy}  {s.label()}")
        return 0
    out = args.out or Path(tempfile.mkdtemp(prefix="chaos-"))
    out.mkdir(parents=True, exist_ok=True)
    print(f"logs under {out}", flush=True)
    outcomes = []
    began = time.monotonic()
    for s in schedules:
        print(f"seed {s.seed}: x{s.speedup:g} busy {s.busy}: {s.label()}", flush=True)
        outcome = chaos.run(s, out / f"seed-{s.seed}")
        outcomes.append(outcome)
        verdict = " ".join(f"{c}={chaos.short(outcome.checks.get(c, '-'))}" for c in chaos.CHECKS)
        print(f"  -> {outcome.state} in {outcome.wall_s:.0f} s: {verdict}", flush=True)
    print()
    print(chaos.table(outcomes))
    print(f"\n{len(outcomes)} schedules in {time.monotonic() - began:.0f} s")
    failed = chaos.failures(outcomes)
    if failed:
        print("\nfailed checks:\n" + failed)
    (out / "outcomes.json").write_text(
        json.dumps([o.as_json() for o in outcomes], indent=1, default=str)
    )
    return 1 if any(o.failed for o in outcomes) else 0


if __name__ == "__main__":
    sys.exit(main())
