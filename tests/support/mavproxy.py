"""MAVProxy (the ArduPilot developers' console ground station, from PyPI) as a process the tests
type into, reading what it prints, as an operator at its ``MAV>`` prompt would.

It is installed without its optional map, graph and 3-D modules (VTK, OpenCV and matplotlib, some
700 MB that the console never loads): see the Makefile.
"""

from __future__ import annotations

import asyncio
import contextlib
import re
import sys
from collections.abc import AsyncIterator
from pathlib import Path

from support.processes import stop_async


class MAVProxy:
    """Commands in, lines out; ``expect`` reads on from where the last match ended."""

    def __init__(self, proc: asyncio.subprocess.Process) -> None:
        self.proc = proc
        self.lines: list[str] = []
        self._cursor = 0
        self._grew = asyncio.Event()

    async def _read(self) -> None:
        assert self.proc.stdout is not None
        while line := await self.proc.stdout.readline():
            self.lines.append(line.decode(errors="replace").rstrip())
            self._grew.set()

    async def send(self, command: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(command.encode() + b"\n")
        await self.proc.stdin.drain()

    async def expect(self, pattern: str, timeout_s: float = 30.0) -> re.Match[str]:
        """The first line from the cursor on that matches ``pattern``; the cursor moves past it."""
        wanted = re.compile(pattern)
        try:
            return await asyncio.wait_for(self._next_match(wanted), timeout_s)
        except TimeoutError:
            seen = "\n".join(self.lines[-40:])
            raise AssertionError(
                f"MAVProxy never printed {pattern!r}; it printed:\n{seen}"
            ) from None

    async def _next_match(self, wanted: re.Pattern[str]) -> re.Match[str]:
        if True:
            while True:
                while self._cursor < len(self.lines):
                    line = self.lines[self._cursor]
                    self._cursor += 1
                    if match := wanted.search(line):
                        return match
                self._grew.clear()
                await self._grew.wait()

    def printed(self) -> str:
        return "\n".join(self.lines)


@contextlib.asynccontextmanager
async def mavproxy(master: str, state_dir: Path) -> AsyncIterator[MAVProxy]:
    """``mavproxy.py --master=MASTER`` with its logs in ``state_dir``, stopped on the way out."""
    script = Path(sys.executable).parent / "mavproxy.py"
    proc = await asyncio.create_subprocess_exec(
        sys.executable, str(script), f"--master={master}", "--nowait",
        f"--state-basedir={state_dir}", cwd=state_dir,
        stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.STDOUT,
    )  # fmt: skip
    console = MAVProxy(proc)
    reader = asyncio.create_task(console._read())
    try:
        yield console
    finally:
        await stop_async(proc)
        reader.cancel()
