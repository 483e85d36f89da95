"""The search behind :func:`.allocation.split_route`: a route's per-unit costs (:class:`_Route`)
and, for a candidate makespan, whether some order of the drones along the route shares it out
within that time and their batteries (:class:`_Search`).

Why the reach sets are prefixes. A drone may also take an empty share, so the starts reachable
by the first m drones always include those of the first m - 1; from a start b the m-th drone
reaches every start in [b + 1, last(b) + 1], where last(b) >= b whenever b is usable at all
(in time and within the battery). Starting from {0}, the union of such intervals over every
reachable b <= R is [0, max(R, max_b last(b) + 1)]: the set stays "every allowed start up to
R" and one integer R describes it. A step is then max over b <= R of last(b), and for the
time limit last(b) = bisect(P, g[b] + T) with g[b] = P[b] - start[b] - hold[b], independent of
T: a running maximum of g, computed once per split, answers a step in O(log n) instead of
the O(n) interval sweep (np.add.at) it replaces — 10 drones over 10 000 waypoints went from
12.5 s to a few tens of ms. Starts that are unusable give last(b) < b <= R and so never count.

Why orders can be skipped. A step never reaches less from a larger reach (the starts up to R
include those up to a smaller R), so two prefixes of orders that used the same drones lead to
the same completions, and the one that reached less cannot end where the other did not: once
every completion of a prefix has failed, a later prefix with those drones and no greater reach
is not walked (issue 30: 10 drones, 720 orders, about 2 000 steps per failing time before).
"""

from __future__ import annotations

import bisect
import itertools
import math
from dataclasses import dataclass

import numpy as np

from dronefleet.geo.types import LLA
from dronefleet.ground.planner.estimate import VehicleModel

#: Current during preparation and transit, as a multiple of hover (a conservative average of
#: climbing and fast forward flight) for the battery budget of a share.
_TRANSIT_CURRENT = 1.3


@dataclass
class _Route:
    xy: np.ndarray  # waypoints, metres east/north of waypoint 0
    leg_s: np.ndarray  # unit i: flying from waypoint i-1 and its wait (0 for i = 0)
    hold_s: np.ndarray  # unit i: what follows the wait (action, hold)
    leg_mah: np.ndarray
    hold_mah: np.ndarray
    starts: np.ndarray  # where a share may begin
    altitude_m: float
    ref: LLA

    @property
    def prefix(self) -> np.ndarray:
        """P[i] = work of units 1..i after the first: legs and holds."""
        return np.concatenate([[0.0], np.cumsum((self.leg_s + self.hold_s)[1:])])

    @property
    def prefix_mah(self) -> np.ndarray:
        return np.concatenate([[0.0], np.cumsum((self.leg_mah + self.hold_mah)[1:])])


class _Search:
    def __init__(
        self,
        r: _Route,
        costs: np.ndarray,
        usable_mah: np.ndarray,
        model: VehicleModel,
        place: list[int],
    ) -> None:
        # start[d, k, b]: drone d at the k-th distinct height, from waypoint b; the m-th share
        # flies at height place[m] (shares at one height are costed once, not once each).
        self.r, self.start, self.place = r, costs, place
        self.prefix, self.prefix_mah = r.prefix, r.prefix_mah
        self.n = len(r.xy)
        self.allowed = np.append(r.starts, True)
        # What each drone may spend on its share's work, less what getting there costs.
        transit_a = model.hover_current_a * _TRANSIT_CURRENT
        self.budget_mah = usable_mah[:, None, None] - costs * transit_a / 3.6
        # g[d, m, b] (see above), -inf where a share may not begin; its running maximum over b
        # and where that maximum is reached.
        g = self.prefix - costs - r.hold_s
        g = np.where(r.starts, g, -np.inf)
        self.g_max = np.maximum.accumulate(g, axis=2)
        at = np.where(g >= self.g_max, np.arange(self.n), 0)
        self.g_arg = np.maximum.accumulate(at, axis=2)
        self._p = self.prefix.tolist()  # bisect on lists: a step is a few scalar operations
        self._e = self.prefix_mah.tolist()
        self._lexical: list[tuple[int, ...]] | None = None  # orders known to be in order

    def _last_by_energy(self, d: int, m: int, b: int) -> int:
        """The last waypoint a share of drone ``d`` (m-th) from ``b`` can afford."""
        left = float(self.budget_mah[d, self.place[m], b] - self.r.hold_mah[b])
        if left < 0:
            return b - 1
        return bisect.bisect_right(self._e, self._e[b] + left) - 1

    def step(self, reach: int, d: int, m: int, limit: float) -> int:
        """The furthest start reachable once drone ``d`` (m-th share) has taken a chunk finishing
        by ``limit``, when the first ``m`` drones reach every allowed start up to ``reach``."""
        top = min(reach, self.n - 1)
        k = self.place[m]
        best = float(self.g_max[d, k, top])
        if best == -np.inf:
            return reach
        b = int(self.g_arg[d, k, top])
        last = bisect.bisect_right(self._p, best + limit + 1e-9) - 1
        if self._last_by_energy(d, m, b) < last:  # the battery binds: look at every start
            last = self._exact(reach, d, m, limit)
        return max(reach, last + 1)

    def _exact(self, reach: int, d: int, m: int, limit: float) -> int:
        top = min(reach, self.n - 1)
        bs = np.flatnonzero(self.r.starts[: top + 1])
        p, e = self.prefix, self.prefix_mah
        k = self.place[m]
        budget = limit - self.start[d, k, bs] - self.r.hold_s[bs]
        energy = self.budget_mah[d, k, bs] - self.r.hold_mah[bs]
        last = np.minimum(
            np.searchsorted(p, p[bs] + budget + 1e-9, side="right") - 1,
            np.searchsorted(e, e[bs] + energy, side="right") - 1,
        )
        usable = (budget >= 0) & (energy >= 0)
        return int(last[usable].max()) if usable.any() else -1

    def first_fit(self, d: int, m: int, e: int, reach: int, limit: float) -> int:
        """The first reachable start from which drone ``d`` (m-th) can fly up to ``e`` by
        ``limit`` (``e`` itself, an empty share, when none can)."""
        bs = np.flatnonzero(self.r.starts[: min(e, reach + 1)])
        if e == 0 or bs.size == 0:
            return e
        r = self.r
        k = self.place[m]
        finish = self.start[d, k, bs] + r.hold_s[bs] + self.prefix[e - 1] - self.prefix[bs]
        mah = r.hold_mah[bs] + self.prefix_mah[e - 1] - self.prefix_mah[bs]
        ok = (finish <= limit + 1e-6) & (mah <= self.budget_mah[d, k, bs] + 1e-6)
        return int(bs[np.argmax(ok)]) if ok.any() else e

    def feasible(self, limit: float, orders: list[tuple[int, ...]]) -> tuple[int, ...] | None:
        """The first of ``orders`` whose shares end by ``limit``, or None."""
        if not orders:
            return None
        if self._lexical is not orders:  # the first permutations of the first, in order?
            first = itertools.permutations(orders[0])
            if orders != list(itertools.islice(first, len(orders))):
                return self._walk(limit, orders)
            self._lexical = orders
        return self._skipping(limit, orders[0], len(orders))

    def _skipping(self, limit: float, base: tuple[int, ...], count: int) -> tuple[int, ...] | None:
        """:meth:`_walk` of the first ``count`` permutations of ``base`` in order, skipping
        prefixes that cannot end (see the module's note): the same answer."""
        failed: dict[int, int] = {}  # drones used (bits) -> the greatest reach found to fail
        order: list[int] = []
        passed = 0  # orders walked or skipped

        def visit(reach: int, used: int, rest: list[int]) -> tuple[int, ...] | None:
            nonlocal passed
            if reach >= self.n:
                return (*order, *rest)
            if not rest:
                passed += 1
                return None
            if failed.get(used, -1) >= reach:
                passed += math.factorial(len(rest))
                return None
            for i, d in enumerate(rest):
                if passed >= count:
                    return None
                order.append(d)
                found = visit(
                    self.step(reach, d, len(order) - 1, limit),
                    used | 1 << d,
                    rest[:i] + rest[i + 1 :],
                )
                order.pop()
                if found is not None:
                    return found
            if passed < count:  # every completion was walked
                failed[used] = max(failed.get(used, -1), reach)
            return None

        return visit(0, 0, list(base))

    def _walk(self, limit: float, orders: list[tuple[int, ...]]) -> tuple[int, ...] | None:
        # One order after another, keeping the reaches of the prefix shared with the one before
        # (a walk of the tree of prefixes, without a dictionary of them).
        previous: tuple[int, ...] = ()
        reaches = [0]
        for order in orders:
            same = 0
            while same < min(len(order), len(previous)) and order[same] == previous[same]:
                same += 1
            del reaches[same + 1 :]
            if reaches[-1] >= self.n:
                return order
            for k in range(same, len(order)):
                reaches.append(self.step(reaches[-1], order[k], k, limit))
                if reaches[-1] >= self.n:
                    return order
            previous = order
        return None

    def finish(self, d: int, m: int, b: int, e: int) -> float:
        return self.cost(d, m, b) + float(self.r.hold_s[b] + self.prefix[e - 1] - self.prefix[b])

    def cost(self, d: int, m: int, b: int) -> float:
        """Seconds until drone ``d``, flying the ``m``-th share, has reached waypoint ``b``."""
        return float(self.start[d, self.place[m], b])
