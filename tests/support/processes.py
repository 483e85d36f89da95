"""``dronefleet`` commands run as processes of their own by the tests."""

from __future__ import annotations

import asyncio
import contextlib
import subprocess
import sys
from collections.abc import AsyncIterator, Iterator
from pathlib import Path


def dronefleet(*args: str) -> list[str]:
    """The command line of ``dronefleet ARGS...`` with this interpreter."""
    return [sys.executable, "-m", "dronefleet.cli", *args]


#: Lines of a process's log printed when the test around it fails.
FAILED_LOG_LINES = 60


@contextlib.contextmanager
def process(cmd: list[str], log: Path) -> Iterator[subprocess.Popen[bytes]]:
    """``cmd`` with its output in ``log``, stopped (terminate, then kill) on the way out.

    If the block fails, the end of the log is printed once the process has stopped: pytest shows
    it with the failure, so a run that fails only on CI still says what the process was doing.
    """
    with open(log, "ab") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT)
    try:
        yield proc
    except BaseException:
        stop(proc)
        lines = log.read_text(errors="replace").splitlines()[-FAILED_LOG_LINES:]
        print(f"--- the end of {log} (exit {proc.returncode}):")
        print("\n".join(lines))
        raise
    finally:
        stop(proc)


def stop(proc: subprocess.Popen[bytes], sig_kill: bool = False) -> None:
    if proc.poll() is not None:
        return
    if sig_kill:
        proc.kill()
    else:
        proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


async def stop_async(proc: asyncio.subprocess.Process) -> None:
    """Terminate an asyncio child process (if still running), killed after 10 s."""
    if proc.returncode is not None:
        return
    proc.terminate()
    try:
        await asyncio.wait_for(proc.wait(), 10)
    except TimeoutError:
        proc.kill()
        await proc.wait()


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
        await stop_async(proc)
        if drain is not None:
            drain.cancel()


@contextlib.asynccontextmanager
async def dronefleet_sim(
    count: int, home: tuple[float, float, float], speedup: float = 5.0
) -> AsyncIterator[int]:
    """``dronefleet sim`` over MAVLink on free UDP ports; yields the first vehicle's port
    (vehicle i answers on that port + i)."""
    from dronefleet.experiments.fleets import free_udp_port

    port = free_udp_port()
    args = ("sim", "--count", str(count), "--speedup", str(speedup),
            "--mavlink", f"udp:127.0.0.1:{port}", "--home", ",".join(map(str, home)))  # fmt: skip
    async with dronefleet_process(*args, ready="sim ready"):
        yield port
