"""The drone's reports kept on disk (issue 13): what it did survives a restart of its software.

Every report the Mission Worker publishes is numbered (``MissionProgress.seq``) and kept for a
replay; with a state folder (``dronefleet drone --state-dir``) it is also written here before it
is sent, so a drone killed with reports still unsent (its broker away, say) sends them after its
restart when the ground asks. SQLite from the standard library: one small insert per report, in
WAL mode with ``synchronous=NORMAL`` (a commit costs no fsync; a kill loses nothing committed,
only a power cut may lose the last few), no server to run on a companion computer.

A mission whose last kept report is not an ending one (completed, failed, stopped) was running
when the software stopped: it is *interrupted*. The restarted drone does not fly it again (it
cannot know what the vehicle did meanwhile); asked for its reports, it sends them all and then
says it no longer flies it, and the planner has the rest taken over (ground/planner/reconcile.py).
"""

from __future__ import annotations

import logging
import sqlite3
from collections import OrderedDict
from pathlib import Path

from dronefleet.errors import InvalidInput
from dronefleet.messaging.codec import MessageError
from dronefleet.messaging.missions import MissionProgress, ProgressEvent
from dronefleet.owner_only import private_file

log = logging.getLogger(__name__)

ENDINGS = frozenset({ProgressEvent.COMPLETED, ProgressEvent.FAILED, ProgressEvent.STOPPED})
_SCHEMA = """
CREATE TABLE IF NOT EXISTS reports (
    mission_id TEXT NOT NULL,
    seq INTEGER NOT NULL,
    body BLOB NOT NULL,
    PRIMARY KEY (mission_id, seq)
)
"""


class ReportStore:
    """Reports on disk (``path``), or nowhere (None: kept in memory only, as before)."""

    def __init__(self, path: Path | None) -> None:
        self.db: sqlite3.Connection | None = None
        if path is not None:
            # 0600 before SQLite opens it, so its -wal and -shm files are too (issue 25).
            private_file(path)
            db = sqlite3.connect(path, isolation_level=None)
            try:
                db.execute("PRAGMA journal_mode=WAL")
                db.execute("PRAGMA synchronous=NORMAL")
                db.execute(_SCHEMA)
                db.execute("SELECT mission_id, seq, body FROM reports LIMIT 0")
            except sqlite3.DatabaseError as exc:  # garbage, or another program's reports table
                db.close()
                raise InvalidInput(f"--state-dir: {path} cannot be used: {exc}") from exc
            self.db = db

    def add(self, progress: MissionProgress) -> None:
        if self.db is None or progress.seq is None:
            return
        body = progress.model_dump_json(exclude_none=True).encode()
        self.db.execute(
            "INSERT OR REPLACE INTO reports VALUES (?, ?, ?)",
            (progress.mission_id, progress.seq, body),
        )

    def load(self, missions: int) -> OrderedDict[str, list[MissionProgress]]:
        """The reports of the last ``missions`` missions, oldest mission first."""
        kept: OrderedDict[str, list[MissionProgress]] = OrderedDict()
        if self.db is None:
            return kept
        rows = self.db.execute(
            "SELECT mission_id, body FROM reports WHERE mission_id IN (SELECT mission_id FROM "
            "reports GROUP BY mission_id ORDER BY max(rowid) DESC LIMIT ?) ORDER BY rowid",
            (missions,),
        )
        for mission_id, body in rows:
            try:
                progress = MissionProgress.model_validate_json(body)
            except (ValueError, MessageError):
                log.warning("report store: an unreadable report of %s skipped", mission_id)
                continue
            kept.setdefault(mission_id, []).append(progress)
            kept.move_to_end(mission_id)
        return kept

    def forget_all_but(self, missions: list[str]) -> None:
        if self.db is None:
            return
        marks = ",".join("?" * len(missions)) or "''"
        self.db.execute(
            f"DELETE FROM reports WHERE mission_id NOT IN ({marks})", missions
        )  # only "?" placeholders

    def close(self) -> None:
        if self.db is not None:
            self.db.close()
            self.db = None


def interrupted(history: OrderedDict[str, list[MissionProgress]]) -> set[str]:
    """Missions whose last report is not an ending: running when the software stopped."""
    return {m for m, kept in history.items() if kept and kept[-1].event not in ENDINGS}
