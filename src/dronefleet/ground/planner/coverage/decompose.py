"""Stage 2 of the coverage pipeline: boustrophedon cell decomposition.

A cell is a run of consecutive swath lines that each cross it in exactly one segment, every
segment overlapping the one before: inside a cell a plain back-and-forth sweep works. Where a line
splits (a hole, a concavity) or two branches merge, cells close and new ones begin — the critical
points of Choset's boustrophedon decomposition, found here from the swath segments themselves.
Flying cell by cell keeps the route regional, so contiguous chunks of it are separate regions
when the work is shared among drones.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from dronefleet.ground.planner.coverage.swaths import SweepLine

#: (line index, offset y, x0, x1) of one segment in the sweep frame.
Segment = tuple[int, float, float, float]


@dataclass
class Cell:
    """Segments on consecutive lines, one per line, each overlapping the previous."""

    segments: list[Segment] = field(default_factory=list)

    @property
    def last(self) -> Segment:
        return self.segments[-1]


def _overlap(a: Segment, b: Segment) -> bool:
    return a[2] <= b[3] and b[2] <= a[3]


@dataclass(frozen=True)
class BoustrophedonDecomposer:
    """Groups the swath segments of the sweep lines into monotone cells."""

    def cells(self, lines: list[SweepLine]) -> list[Cell]:
        done: list[Cell] = []
        open_cells: list[Cell] = []
        for line in lines:
            segs = [(line.index, line.y, x0, x1) for x0, x1 in line.segments]
            links = {id(cell): [s for s in segs if _overlap(cell.last, s)] for cell in open_cells}
            owners: dict[Segment, list[Cell]] = {s: [] for s in segs}
            for cell in open_cells:
                for s in links[id(cell)]:
                    owners[s].append(cell)
            still_open: list[Cell] = []
            for cell in open_cells:
                nxt = links[id(cell)]
                if len(nxt) == 1 and len(owners[nxt[0]]) == 1:
                    cell.segments.append(nxt[0])
                    still_open.append(cell)
                else:
                    done.append(cell)
            continued = {id(c.last) for c in still_open}
            for s in segs:
                if id(s) not in continued:
                    still_open.append(Cell([s]))
            open_cells = still_open
        done.extend(open_cells)
        return [c for c in done if c.segments]
