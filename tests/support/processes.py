"""``dronefleet`` commands run as processes of their own by the tests."""

from __future__ import annotations

import asyncio
import contextlib
import sys
from collections.abc import AsyncIterator


@contextlib.asynccontextmanager
async def dronefleet_process(
    *args: str, ready: str, timeout_s: float = 30.0
) -> AsyncIterator[tuple[asyncio.subprocess.Process, list[str]]]:
    """``dronefleet ARGS...`` until a line containing ``ready``; yields the process and its lines.

    Its output is drained afterwards so the pipe never fills; it is terminated (killed if it
    will not stop) on the way out.
    """
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "dronefleet.cli", *args,
        stdout=asyncio.subprocess.PIPE, stderr=asyncio.subprocess.STDOUT,
    )  # fmt: skip
    drain = None
    try:
        lines: list[str] = []
        while True:
            line = (await asyncio.wait_for(proc.stdout.readline(), timeout_s)).decode()
            if not line:
                raise RuntimeError(f"dronefleet {args[0]} exited: " + "".join(lines))
            lines.append(line)
            if ready in line:
                break
        drain = asyncio.create_task(proc.stdout.read())
        yield proc, lines
    finally:
        if proc.returncode is None:
            proc.terminate()
            try:
                await asyncio.wait_for(proc.wait(), 10)
            except TimeoutError:
                proc.kill()
                await proc.wait()
        if drain is not None:
            drain.cancel()
