"""One log line per record: text from the network cannot forge log lines (issue 12).

Drone ids, topics, broker payloads and HTTP paths end up in log messages; one carrying a newline
("...\\n12:00:01 WARNING dronefleet.ground: drone QUAD_1 armed by operator") would write a line
that never happened. The message part of every record is escaped here: CR, LF and the other
control characters become ``\\r``, ``\\n``, ``\\xNN``. A traceback (``exc_info``), added after the
message, keeps its own lines. The standard library's Formatter is kept for everything else.
"""

from __future__ import annotations

import logging

#: Control characters (C0, DEL, C1) and their escapes; tab is kept.
_ESCAPES = {
    c: ("\\n" if c == 10 else "\\r" if c == 13 else f"\\x{c:02x}")
    for c in [*range(0x20), 0x7F, *range(0x80, 0xA0)]
    if c != 9
}
_ESCAPES.update({0x2028: "\\u2028", 0x2029: "\\u2029"})  # line and paragraph separators


class OneLineFormatter(logging.Formatter):
    def formatMessage(self, record: logging.LogRecord) -> str:
        return super().formatMessage(record).translate(_ESCAPES)


def escape(text: str) -> str:
    """``text`` on one line, its control characters escaped."""
    return text.translate(_ESCAPES)
