"""``python -m dronefleet.sim.uavtalk``: simulated vehicles over UAVTalk (see :mod:`.cli`)."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import signal

from dronefleet.sim.uavtalk.cli import add_arguments, serve


async def _main(args: argparse.Namespace) -> None:
    task = asyncio.create_task(serve(args))
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        with contextlib.suppress(NotImplementedError):
            loop.add_signal_handler(sig, task.cancel)
    with contextlib.suppress(asyncio.CancelledError):
        await task


def main() -> None:
    parser = argparse.ArgumentParser(
        prog="python -m dronefleet.sim.uavtalk",
        description="Serve simulated dRonin flight controllers over UAVTalk (TCP).",
    )
    add_arguments(parser)
    parser.add_argument("--log-level", default="WARNING", help="DEBUG, INFO, WARNING, ...")
    args = parser.parse_args()
    logging.basicConfig(level=args.log_level.upper(), format="%(levelname)s %(name)s: %(message)s")
    asyncio.run(_main(args))


if __name__ == "__main__":
    main()
