"""The Logger (seed 3.3.2.5, 4.1.3): records everything said on the drone's topics and local events.

It subscribes to ``<id>/#`` on the internal broker and writes one JSON line per message,
``{"t": <unix s>, "topic": ..., "payload": <the JSON, or {"raw": text}>}``, to
``<log_dir>/<drone_id>.jsonl``, rotating to ``.jsonl.1`` ... ``.jsonl.<backups>``. Components on the
same host add events that never reach the broker (arming switch interactions, decode timings) with
:meth:`DroneLogger.log_event`, written as ``{"t": ..., "event": kind, "data": {...}}``.

Like the seed's, it never publishes. Each line is flushed as it is written, so a crash of the
process loses nothing already received (an OS crash may lose what the OS had not yet written).
The logs are the owner's only: files 0600, folders made 0700 (issue 25).
"""

from __future__ import annotations

import contextlib
import logging
import os
from pathlib import Path
from typing import Any, BinaryIO

import orjson

from dronefleet.clock import timestamp_s
from dronefleet.messaging import topics
from dronefleet.messaging.client import QOS_COMMAND, BrokerClient
from dronefleet.owner_only import open_private

log = logging.getLogger(__name__)


def _parse(payload: bytes) -> Any:
    try:
        return orjson.loads(payload)
    except orjson.JSONDecodeError:
        return {"raw": payload.decode("utf-8", errors="replace")}


class DroneLogger:
    """Writes every message on ``<drone_id>/#`` and every local event to rotating JSON-lines."""

    def __init__(
        self,
        drone_id: str,
        client: BrokerClient,
        log_dir: Path,
        *,
        max_bytes: int = 10_000_000,
        backups: int = 5,
    ) -> None:
        self.drone_id = topics.check_drone_id(drone_id)
        self.client = client
        self.log_dir = Path(log_dir)
        self.max_bytes = max_bytes
        self.backups = max(0, backups)
        self.path = self.log_dir / f"{drone_id}.jsonl"
        self.lines_written = 0
        self._file: BinaryIO | None = None
        self._size = 0
        self._subscribed = False
        self._running = False

    async def start(self) -> None:
        self._open()
        self._running = True
        if not self._subscribed:
            await self.client.subscribe(
                topics.drone_all(self.drone_id), self._on_message, qos=QOS_COMMAND
            )
            self._subscribed = True

    async def stop(self) -> None:
        self._running = False
        if self._file is not None:
            self._file.close()
            self._file = None

    async def _on_message(self, topic_name: str, payload: bytes) -> None:
        if self._running:
            self._write({"t": timestamp_s(), "topic": topic_name, "payload": _parse(payload)})

    def log_event(self, kind: str, **data: Any) -> None:
        """Record a local event, e.g. ``log_event("arm", requested_by="mission", ok=True)``."""
        self._write({"t": timestamp_s(), "event": kind, "data": data})

    # -- file handling -----------------------------------------------------------------------
    def _write(self, record: dict[str, Any]) -> None:
        try:
            line = orjson.dumps(record, default=repr, option=orjson.OPT_NON_STR_KEYS) + b"\n"
        except (TypeError, orjson.JSONEncodeError) as exc:
            line = (
                orjson.dumps({"t": record["t"], "unloggable": repr(record), "error": str(exc)})
                + b"\n"
            )
        try:
            if self._file is None:
                self._open()
            if self._size and self._size + len(line) > self.max_bytes:
                self._rotate()
            assert self._file is not None
            self._file.write(line)
            self._file.flush()
            self._size += len(line)
            self.lines_written += 1
        except OSError as exc:  # disk full, directory removed: log it, keep running
            log.error("logger: cannot write %s: %s", self.path, exc)
            if self._file is not None:
                with contextlib.suppress(OSError):
                    self._file.close()
            self._file = None

    def _open(self) -> None:
        if self._file is None:
            self._file = open_private(self.path, append=True)  # kept open across writes
            self._size = self._file.seek(0, os.SEEK_END)

    def _rotate(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
        if self.backups == 0:
            self.path.unlink(missing_ok=True)
        else:
            for i in range(self.backups - 1, 0, -1):
                older = self.path.with_name(f"{self.path.name}.{i}")
                if older.exists():
                    os.replace(older, self.path.with_name(f"{self.path.name}.{i + 1}"))
            os.replace(self.path, self.path.with_name(f"{self.path.name}.1"))
        self._open()
