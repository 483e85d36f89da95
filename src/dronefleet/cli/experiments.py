"""``dronefleet experiment NAME [--speedup N|max] [--json] [--baseline seed] [--fc BACKEND]``:
the seed's chapter 5, on in-process, MAVLink, UAVTalk or mixed flight controllers.

Every experiment runs in one process on virtual time (:mod:`dronefleet.virtual_loop`): its
figures are vehicle seconds that do not depend on ``--speedup`` or on the machine's load.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys

from dronefleet import virtual_loop

EXAMPLES = """examples:
  dronefleet experiment survey
      the seed's survey experiment as fast as the CPU allows, stage by stage
  dronefleet experiment replacement --baseline seed --json
      ours and the seed's strategy side by side, as one JSON object
"""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "experiment", help="run one of the seed's four experiments (chapter 5)", epilog=EXAMPLES
    )
    p.add_argument(
        "name",
        choices=["panic", "survey", "replacement", "collab"],
        help="which experiment: panic (a call), survey (an area), replacement (a low battery), "
        "collab (a reading calls others)",
    )
    p.add_argument(
        "--speedup",
        type=virtual_loop.speedup_arg,
        default="max",
        help="vehicle seconds per wall second at most, or 'max' (default): as fast as the CPU "
        "allows; the figures are the same at any speed-up",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument(
        "--baseline",
        choices=["seed"],
        help="also run the seed's own strategy in the same simulator, side by side",
    )
    p.add_argument(
        "--strategy",
        choices=["ours", "seed"],
        default="ours",
        help="whose way to fly it: ours, or the seed's (stop at every photo, take off then fly, "
        "equal split)",
    )
    p.add_argument(
        "--fc",
        choices=["sim", "mavlink", "uavtalk", "mixed"],
        default="sim",
        help="flight controllers: in-process, simulated vehicles over MAVLink UDP or UAVTalk "
        "TCP, or a mix (all in one simulated world)",
    )
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from dronefleet.experiments.scenarios import run

    strategies = [args.strategy] + (["seed"] if args.baseline and args.strategy != "seed" else [])
    results = []
    for strategy in strategies:
        if not args.json:
            print(
                f"running {args.name} ({strategy}, fc {args.fc}) at {args.speedup:g}x ...",
                file=sys.stderr,
            )
        try:
            results.append(
                virtual_loop.run(
                    run(args.name, strategy=strategy, speedup=args.speedup, fc=args.fc),
                    speedup=args.speedup,
                )
            )
        except Exception as exc:  # one clear line (and a JSON object), never a traceback
            logging.getLogger(__name__).debug("experiment failed", exc_info=True)
            message = str(exc) or type(exc).__name__
            if args.json:
                print(json.dumps({"experiment": args.name, "strategy": strategy, "error": message}))
            else:
                print(f"dronefleet experiment: {message}", file=sys.stderr)
            return 1
    if args.json:
        data = results[0].as_json()
        if len(results) > 1:
            data["baseline"] = results[1].as_json()
            data["ratio_to_baseline"] = round(results[0].total_s / results[1].total_s, 3)
        print(json.dumps(data))
    else:
        for result in results:
            print(result.table())
        if len(results) > 1:
            print(f"ours / seed baseline: {results[0].total_s / results[1].total_s:.2f}")
    return 0
