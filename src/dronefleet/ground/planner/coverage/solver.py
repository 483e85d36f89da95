"""Stage 4b of the coverage pipeline: the order of the swaths over the whole field.

Flying cell after cell (:class:`~.route.BoustrophedonOrderer`) is a good route for a convex field
and a poor one where cells could share their turns: round a pond, the swaths either side of it
are best flown as one back-and-forth, and the arms of a U are cheaper joined along the base than
one after the other. Fields2Cover orders swaths with OR-tools' routing solver. OR-tools is not
used here: ortools 9.15 (the newest) needs protobuf >= 6.33.1, < 6.34, and the project pins
protobuf 7.36.2 (constraints.txt, for MAVSDK's gRPC), so pip cannot install both. The problem is
small anyway — tens of swaths, a hundred on a square kilometre — and a local search finds good
routes within milliseconds (an iterated local search with random kicks found 3 % cheaper
transits on the field with a pond, in over 100 times the time: not worth a planning budget):

* each swath is flown whole, in either direction; a route is an open path through all of them
  whose cost is the sum of its transits (:class:`~.transits.TransitTable`: metres + bends, the
  shortest way inside the area);
* two starting routes: the cell-by-cell boustrophedon and a greedy nearest-end route (up to
  :attr:`RouteSolver.greedy_up_to` swaths);
* each is improved to a local optimum by the best 2-opt move (reverse a stretch of the route,
  flipping every swath in it), or-opt move (move one to three consecutive swaths elsewhere,
  either way round) and block move (turn every swath of a stretch round, in the same or the
  reverse order: a U's arm entered at the wrong end), each neighbourhood scored at once as a
  numpy matrix;
* the cheaper result is kept (the boustrophedon one on a tie), so the route is never worse than
  flying cell by cell, and the same field always gives the same route (no randomness, no clock).

The number of moves is bounded (:attr:`RouteSolver.max_moves`), so a worker's time is bounded
too; each move costs O(n²) numpy work for n swaths.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

#: A move must gain more than this (m) to be taken: float noise never loops the search.
GAIN_M = 1e-6

#: A route: (swath, reversed) in flying order. Swath ``s`` has ends ``2s`` (left) and ``2s + 1``.
Order = list[tuple[int, bool]]


def ends_of(order: Order) -> tuple[np.ndarray, np.ndarray]:
    """Entry and exit end of each swath of ``order``."""
    s = np.array([k for k, _ in order], dtype=int)
    rev = np.array([r for _, r in order], dtype=int)
    return 2 * s + rev, 2 * s + 1 - rev


def route_cost(cost: np.ndarray, order: Order) -> float:
    """The sum of the transits of ``order``."""
    entry, exit_ = ends_of(order)
    return float(cost[exit_[:-1], entry[1:]].sum()) if len(order) > 1 else 0.0


@dataclass(frozen=True)
class RouteSolver:
    """Improves swath orders by 2-opt and or-opt over a symmetric end-to-end cost matrix."""

    max_moves: int = 2000
    chain: int = 3  # longest run of swaths or-opt moves
    #: Most swaths for which a greedy route is improved too (past that the cell route is a
    #: far better start, and a second local search costs more than it finds).
    greedy_up_to: int = 60
    greedy_starts: int = 1  # greedy routes tried, from ends far apart

    def solve(self, cost: np.ndarray, initial: Order, start_end: int | None = None) -> Order:
        """The best of ``initial`` and a greedy route, each improved to a local optimum."""
        if len(initial) < 2:
            return list(initial)
        first = self.improve(cost, initial)
        if len(initial) > self.greedy_up_to:
            return first
        best, best_cost = first, route_cost(cost, first)
        for end in self._starts(cost, len(initial), start_end):
            route = self.improve(cost, self.greedy(cost, len(initial), end))
            if route_cost(cost, route) < best_cost - GAIN_M:
                best, best_cost = route, route_cost(cost, route)
        return best

    def _starts(self, cost: np.ndarray, n: int, start_end: int | None) -> list[int]:
        """Ends the greedy routes start from: ``start_end`` and the ends farthest apart (a
        route over a field usually begins at a corner of it)."""
        first = 0 if start_end is None else start_end
        ends = [first]
        spread = np.where(np.isfinite(cost), cost, 0.0)
        for _ in range(self.greedy_starts - 1):
            far = int(np.argmax(spread[ends].min(axis=0)))
            if far in ends:
                break
            ends.append(far)
        return ends

    @staticmethod
    def greedy(cost: np.ndarray, n: int, start_end: int | None) -> Order:
        """From ``start_end`` (default: end 0), always on to the nearest end of a swath left."""
        here = 0 if start_end is None else start_end
        order: Order = [(here // 2, bool(here % 2))]
        left = np.ones(2 * n, dtype=bool)
        left[2 * (here // 2) : 2 * (here // 2) + 2] = False
        exit_ = here ^ 1
        for _ in range(n - 1):
            nxt = int(np.argmin(np.where(left, cost[exit_], np.inf)))
            order.append((nxt // 2, bool(nxt % 2)))
            left[2 * (nxt // 2) : 2 * (nxt // 2) + 2] = False
            exit_ = nxt ^ 1
        return order

    def improve(self, cost: np.ndarray, order: Order) -> Order:
        """``order`` after the best 2-opt and or-opt moves until neither gains."""
        n = len(order)
        # Pad the matrix with a free end (index 2n) at both ends of the route: an open path.
        padded = np.zeros((2 * n + 1, 2 * n + 1))
        padded[: 2 * n, : 2 * n] = cost
        entry, exit_ = ends_of(order)
        e = np.concatenate(([2 * n], entry, [2 * n]))
        x = np.concatenate(([2 * n], exit_, [2 * n]))
        moves = 0
        while moves < self.max_moves:
            if _two_opt(padded, e, x):
                moves += 1
                continue
            if _or_opt(padded, e, x, self.chain):
                moves += 1
                continue
            if _turn_blocks(padded, e, x):
                moves += 1
                continue
            break
        return [(int(a // 2), bool(a % 2)) for a in e[1:-1]]


def _two_opt(c: np.ndarray, e: np.ndarray, x: np.ndarray) -> bool:
    """Reverse the stretch of the route that gains most (in place); whether one gained."""
    n = len(e) - 2
    p, q, r, s = x[:n], e[1 : n + 1], x[1 : n + 1], e[2:]
    # Reversing positions i..j (1-based in the padded arrays) replaces the transits
    # x[i-1] -> e[i] and x[j] -> e[j+1] by x[i-1] -> x[j] and e[i] -> e[j+1].
    delta = c[p][:, r] + c[q][:, s]
    delta -= c[p, q][:, None] + c[r, s][None, :]
    delta[_below(n)] = np.inf
    k = int(np.argmin(delta))
    if delta.flat[k] >= -GAIN_M:
        return False
    i, j = divmod(k, n)
    a, b = i + 1, j + 1
    e[a : b + 1], x[a : b + 1] = x[a : b + 1][::-1].copy(), e[a : b + 1][::-1].copy()
    return True


@functools.lru_cache(maxsize=8)
def _below(n: int) -> np.ndarray:
    """The (n, n) mask under the diagonal (reversals i..j need i <= j)."""
    return np.tri(n, n, -1, dtype=bool)


def _or_opt(c: np.ndarray, e: np.ndarray, x: np.ndarray, chain: int) -> bool:
    """Move the run of 1..``chain`` swaths that gains most elsewhere (in place)."""
    n = len(e) - 2
    best = (-GAIN_M, 0, 0, 0, False)
    xk, ek = x[:-1], e[1:]  # insert between padded positions k and k + 1, k = 0..n
    base = c[xk, ek]
    ks = np.arange(n + 1)
    for size in range(1, min(chain, n - 1) + 1):
        a = np.arange(1, n - size + 2)  # first position of the run
        z = a + size - 1  # its last
        gain = c[x[a - 1], e[a]] + c[x[z], e[z + 1]] - c[x[a - 1], e[z + 1]]
        rows_a, rows_z = c[e[a]], c[x[z]]  # the matrix is symmetric: rows serve as columns
        keep = rows_a[:, xk] + rows_z[:, ek]  # x[k] -> e[a] ... x[z] -> e[k+1]
        turn = rows_z[:, xk] + rows_a[:, ek]  # x[k] -> x[z] ... e[a] -> e[k+1], run reversed
        flip = turn < keep
        delta = np.where(flip, turn, keep) - base[None, :] - gain[:, None]
        delta[(ks[None, :] >= (a - 1)[:, None]) & (ks[None, :] <= z[:, None])] = np.inf
        k = int(np.argmin(delta))
        if delta.flat[k] < best[0]:
            i, j = divmod(k, n + 1)
            best = (float(delta.flat[k]), size, int(a[i]), j, bool(flip[i, j]))
    if best[0] >= -GAIN_M:
        return False
    _, size, a0, k0, rev = best
    run = list(zip(e[a0 : a0 + size].tolist(), x[a0 : a0 + size].tolist(), strict=True))
    if rev:
        run = [(xx, ee) for ee, xx in run[::-1]]
    rest = list(zip(e.tolist(), x.tolist(), strict=True))
    del rest[a0 : a0 + size]
    at = k0 + 1 if k0 < a0 else k0 + 1 - size
    rest[at:at] = run
    e[:] = [p for p, _ in rest]
    x[:] = [q for _, q in rest]
    return True


def _turn_blocks(c: np.ndarray, e: np.ndarray, x: np.ndarray) -> bool:
    """Fly a stretch of the route with every swath turned round, in the same order or in the
    reverse order (in place); whether one gained.

    The parity trap these get out of: seven swaths down one arm of a U entered at the wrong end
    leave the route at the far side of the arm, and no 2-opt or or-opt step alone fixes that
    without first making the route worse: every transit in the arm changes side at once."""
    n = len(e) - 2
    if n < 2:
        return False
    pos = np.arange(1, n + 1)
    # Transits inside a stretch i..j: now x[k] -> e[k+1]; turned round, e[k] -> x[k+1]; in
    # reverse order with the swaths as they are, x[k+1] -> e[k]. Summed by prefix.
    now = c[x[1:n], e[2 : n + 1]]
    turned = np.concatenate(([0.0], np.cumsum(c[e[1:n], x[2 : n + 1]] - now)))
    backward = np.concatenate(([0.0], np.cumsum(c[x[2 : n + 1], e[1:n]] - now)))
    i, j = pos[:, None], pos[None, :]
    inner_t = turned[j - 1] - turned[i - 1]
    inner_b = backward[j - 1] - backward[i - 1]
    before, after = x[i - 1], e[j + 1]
    was = c[before, e[i]] + c[x[j], after]
    flip = inner_t + c[before, x[i]] + c[e[j], after] - was
    back = inner_b + c[before, e[j]] + c[x[i], after] - was
    upper = j >= i
    flip = np.where(upper, flip, np.inf)
    back = np.where(upper & (j > i), back, np.inf)
    kf, kb = int(np.argmin(flip)), int(np.argmin(back))
    if min(flip.flat[kf], back.flat[kb]) >= -GAIN_M:
        return False
    if flip.flat[kf] <= back.flat[kb]:
        a, b = divmod(kf, n)
        a, b = a + 1, b + 1
        e[a : b + 1], x[a : b + 1] = x[a : b + 1].copy(), e[a : b + 1].copy()
    else:
        a, b = divmod(kb, n)
        a, b = a + 1, b + 1
        e[a : b + 1], x[a : b + 1] = e[a : b + 1][::-1].copy(), x[a : b + 1][::-1].copy()
    return True
