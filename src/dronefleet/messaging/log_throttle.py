"""At most one log line per key per interval, with how many were held back (issue 11).

A flood of 400,000 bad messages once grew a drone's log by 33 MB: every drop and every handler
error wrote its own line. Here the first occurrence is logged at once and later ones within the
interval are counted and reported with the next line for that key.
"""

from __future__ import annotations

import logging
import time


class LogThrottle:
    def __init__(self, logger: logging.Logger, interval_s: float = 10.0) -> None:
        self.logger = logger
        self.interval_s = interval_s
        self._last: dict[str, float] = {}
        self._held: dict[str, int] = {}

    def log(self, level: int, key: str, message: str, *args: object, exc: bool = False) -> None:
        now = time.monotonic()  # wall time: this paces what a person reads
        last = self._last.get(key)
        if last is not None and now - last < self.interval_s:
            self._held[key] = self._held.get(key, 0) + 1
            return
        held = self._held.pop(key, 0)
        self._last[key] = now
        if held:
            message += f" (and {held} more like it in the last %.0f s)"
            args = (*args, now - last if last is not None else 0.0)
        self.logger.log(level, message, *args, exc_info=exc)


class ThrottleFilter(logging.Filter):
    """The same throttle for a library's logger: at most one record per message template per
    interval (aiomqtt writes "Message queue is full. Discarding message." for every message)."""

    def __init__(self, interval_s: float = 10.0) -> None:
        super().__init__()
        self.interval_s = interval_s
        self._last: dict[str, float] = {}

    def filter(self, record: logging.LogRecord) -> bool:
        now = time.monotonic()
        key = str(record.msg)
        if now - self._last.get(key, -self.interval_s) < self.interval_s:
            return False
        self._last[key] = now
        return True
