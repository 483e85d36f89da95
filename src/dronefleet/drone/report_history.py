"""The reports a drone keeps (issue 13): numbered, kept for a replay, on disk with a state folder.

Every progress report of a mission gets the next number of that mission (``MissionProgress.seq``,
from 1): the ground finds a gap in them and asks for the mission's reports again. The last
:data:`HISTORY_MISSIONS` missions' reports are kept for that (and with a state folder written to
disk first, drone/report_store.py, so a restart loses none). A replay of one mission is answered
at most once per :data:`REPLAY_GAP_S` vehicle seconds: 20 report requests once made a drone
publish 100,040 messages (issue 11).
"""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

from dronefleet.clock import Clock
from dronefleet.drone.report_store import ReportStore, interrupted
from dronefleet.messaging.missions import MAX_STEPS, MissionProgress, ProgressEvent

#: Missions whose reports are kept, and reports kept per mission (a step each, and a few more).
HISTORY_MISSIONS = 20
REPORTS_PER_MISSION = MAX_STEPS + 16
REPLAY_GAP_S = 2.0


class ReportHistory:
    def __init__(self, clock: Clock, path: Path | None = None) -> None:
        self.clock = clock
        self.store = ReportStore(path)
        self.kept: OrderedDict[str, list[MissionProgress]] = self.store.load(HISTORY_MISSIONS)
        self._numbered = {m: max(p.seq or 0 for p in kept) for m, kept in self.kept.items()}
        self.interrupted = interrupted(self.kept)  # running when the software stopped
        self._replayed: dict[str, float] = {}  # mission id -> vehicle time of its last replay

    def keep(self, progress: MissionProgress) -> None:
        """Number ``progress`` and keep it (on disk first, with a store); not a rejection, which
        answers a request that never became a mission."""
        mission_id = progress.mission_id
        if not mission_id or progress.event is ProgressEvent.REJECTED:
            return
        kept = self.kept.setdefault(mission_id, [])
        progress.seq = self._numbered[mission_id] = self._numbered.get(mission_id, 0) + 1
        self.store.add(progress)
        kept.append(progress)
        del kept[:-REPORTS_PER_MISSION]
        self.kept.move_to_end(mission_id)
        if len(self.kept) > HISTORY_MISSIONS:
            while len(self.kept) > HISTORY_MISSIONS:
                self._numbered.pop(self.kept.popitem(last=False)[0], None)
            self.store.forget_all_but(list(self.kept))

    def replay(self, mission_id: str) -> list[MissionProgress] | None:
        """The reports of ``mission_id`` to send again, in order (empty: none kept), or None when
        they were just sent (a burst of requests gets one replay)."""
        now = self.clock.now()
        last = self._replayed.get(mission_id)
        if last is not None and now - last < REPLAY_GAP_S:
            return None
        self._replayed[mission_id] = now
        while len(self._replayed) > HISTORY_MISSIONS:
            self._replayed.pop(next(iter(self._replayed)))
        return list(self.kept.get(mission_id, []))

    def close(self) -> None:
        self.store.close()
