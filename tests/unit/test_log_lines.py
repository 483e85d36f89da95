"""Log lines cannot be forged through what is logged (issue 12): one record, one line."""

from __future__ import annotations

import io
import logging
import subprocess
import sys

from dronefleet.log_lines import OneLineFormatter, escape


def test_a_message_with_newlines_stays_on_its_line() -> None:
    out = io.StringIO()
    handler = logging.StreamHandler(out)
    handler.setFormatter(OneLineFormatter("%(levelname)s %(name)s: %(message)s"))
    log = logging.getLogger("test.lines")
    log.addHandler(handler)
    log.propagate = False
    try:
        forged = "QUAD_1\n12:00:01 WARNING dronefleet.ground: drone QUAD_9 armed\r\x1b[2J"
        log.warning("dropping a heartbeat from %s", forged)
        try:
            raise ValueError("boom")
        except ValueError:
            log.exception("failed on %s", "a\nb")
    finally:
        log.removeHandler(handler)
    lines = out.getvalue().splitlines()
    assert lines[0] == (
        "WARNING test.lines: dropping a heartbeat from QUAD_1\\n12:00:01 WARNING "
        "dronefleet.ground: drone QUAD_9 armed\\r\\x1b[2J"
    )
    assert lines[1] == "ERROR test.lines: failed on a\\nb"
    assert lines[2] == "Traceback (most recent call last):"  # a traceback keeps its lines
    assert escape("tab\tkept\u2028") == "tab\tkept\\u2028"


def test_the_cli_logs_one_line_per_record() -> None:
    code = (
        "import logging; from dronefleet.cli import setup_logging; setup_logging(0); "
        "logging.getLogger('x').warning('id %s', 'A\\nFORGED line')"
    )
    err = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True).stderr
    assert len(err.splitlines()) == 1 and "A\\nFORGED line" in err, err
