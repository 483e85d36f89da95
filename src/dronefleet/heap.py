"""The cyclic garbage collector set for a long-running process that handles a stream.

CPython's collector runs a young collection every 700 allocations net and, every so often, a
full one that walks every tracked object. A process that keeps a large, long-lived state (a
simulated fleet: 445 MB for 1000 drones; a ground's tracks, records and routes) and allocates
a few objects per message (each telemetry message is a decoded dict and a model) paid for both
over and over. Once the process is up, :func:`settle_heap` moves what exists into the
permanent generation (``gc.freeze``: never scanned again) and makes young collections rarer;
reference counting still frees nearly everything at once, the collector being only for cycles.

Measured: bench/sim_scale.py, 1000 drones, 0.10 -> 0.16 vehicle s per wall s; a ground replica
(bench/scale_out.py --replicas --partition, 600 drones), 0.095 -> 0.072 ms of CPU per message
alone and 0.051 -> 0.039 ms with three replicas. Young collections every 20,000 allocations net
then took 0.5-0.6 s of every 10 on a replica of 10,000 drones on 4 hosts (about one a second,
50-70 ms each; bench/replica_share.py, issue 27); every 100,000, none in 30 s: what a message
allocates is freed by reference counting, and what is left young grows by some hundreds of
objects a second, so a young collection comes every few minutes.
"""

from __future__ import annotations

import gc

#: Net allocations between young collections (CPython's default: 700), and how many of each
#: generation before the next is collected (default 10, 10). At most 100,000 young objects
#: wait for a collection: a few tens of MB at the most.
THRESHOLDS = (100_000, 20, 20)


def settle_heap() -> None:
    """Once the process is up: what it holds now is frozen, and young collections are rarer."""
    gc.collect()
    gc.freeze()
    gc.set_threshold(*THRESHOLDS)
