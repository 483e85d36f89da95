"""``dronefleet drone``: run one drone's software (normally on its companion computer)."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import logging
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dronefleet.cli.args import (
    add_broker_password,
    add_signing_key,
    broker_url,
    broker_with_password,
    given_options,
    note_given,
    positive_speedup,
    signing_key,
)
from dronefleet.geo.types import LLA
from dronefleet.signals import stop_event

if TYPE_CHECKING:
    from dronefleet.drone.simulated_sensor import SimulatedSensor
    from dronefleet.vehicle.base import FlightController

log = logging.getLogger(__name__)

DEFAULT_HOME = "40.63,-8.659,10"  # a field on the University of Aveiro campus, the seed's site

#: The options only some backends use, with what they are for (issue 28, item 6): given with any
#: other backend, the command refuses them (one line, exit 2) instead of ignoring them. Options
#: not listed here apply to every backend (``--plume``: the simulated vehicle's gas field, or a
#: simulated gas sensor on an autopilot's companion computer).
BACKEND_OPTIONS: dict[str, tuple[tuple[str, ...], str]] = {
    "fc_url": (("mavlink", "uavtalk"), "an autopilot's link; the simulated vehicle is in-process"),
    "mavlink_signing_key_file": (("mavlink",), "MAVLink 2 signing"),
    "onboard_missions": (("mavlink",), "missions flown on board in MAVLink AUTO"),
    "set_autopilot_failsafe": (("mavlink",), "the autopilot's GCS failsafe parameters"),
    "home": (("sim",), "an autopilot has its own home"),
    "speedup": (("sim",), "an autopilot keeps its own time"),
    "battery_pct": (("sim",), "an autopilot reports its own battery"),
    "wind": (("sim",), "an autopilot flies in the weather's wind or its simulator's"),
}


def parse_lla(text: str) -> LLA:
    try:
        parts = [float(p) for p in text.split(",")]
        if len(parts) == 2:
            parts.append(0.0)
        lat, lon, alt = parts
        return LLA(lat, lon, alt)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(
            f"expected LAT,LON[,ALT] in degrees/metres: {exc}"
        ) from exc


def parse_bound(text: str) -> tuple[str, tuple[float | None, float | None]]:
    try:
        name, low, high = text.split(":")
        return name, (float(low) if low else None, float(high) if high else None)
    except ValueError as exc:
        raise argparse.ArgumentTypeError("expected FIELD:LOW:HIGH, e.g. co2_ppm::1000") from exc


def parse_plume(text: str) -> tuple[float, float, float, float]:
    try:
        lat, lon, peak, radius = (float(p) for p in text.split(","))
    except ValueError as exc:
        raise argparse.ArgumentTypeError("expected LAT,LON,PEAK_PPM,RADIUS_M") from exc
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise argparse.ArgumentTypeError(
            f"a plume's centre is LAT -90..90, LON -180..180: {text!r}"
        )
    if not (math.isfinite(peak) and math.isfinite(radius) and radius > 0):
        raise argparse.ArgumentTypeError(
            f"a plume's PEAK_PPM is a number and its RADIUS_M positive: {text!r}"
        )
    return lat, lon, peak, radius


def parse_wind(text: str) -> tuple[float, float]:
    """``SPEED@FROM``: metres a second and the bearing it blows from (``8@270``: 8 m/s westerly)."""
    try:
        speed, origin = (float(p) for p in text.split("@"))
    except ValueError as exc:
        raise argparse.ArgumentTypeError("expected SPEED_MPS@FROM_DEG, e.g. 8@270") from exc
    if not (0 <= speed <= 50 and 0 <= origin <= 360):
        raise argparse.ArgumentTypeError("wind speed 0-50 m/s, from 0-360 degrees")
    return speed, origin


def add_sim_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--home", type=parse_lla, default=DEFAULT_HOME, help="LAT,LON,ALT")
    p.add_argument(
        "--speedup", type=positive_speedup, default=1.0, help="vehicle seconds per wall second"
    )
    p.add_argument("--battery-pct", type=float, default=100.0, help="initial charge (sim)")
    p.add_argument(
        "--plume",
        type=parse_plume,
        action="append",
        default=[],
        help="a CO2 plume, LAT,LON,PEAK_PPM,RADIUS_M (repeatable): the simulated vehicle's gas "
        "field or, with --fc mavlink/uavtalk, a simulated CO2 sensor on the companion computer "
        "reading it where the autopilot says the vehicle is (centred on the ground at home)",
    )
    p.add_argument(
        "--wind", type=parse_wind, help="steady wind on the simulated vehicle: SPEED_MPS@FROM_DEG"
    )


EXAMPLES = """examples:
  dronefleet drone --id QUAD_1 --broker mqtt://QUAD_1@127.0.0.1:1883 \\
      --broker-password-file QUAD_1.secret --fc sim --home 40.63,-8.659,10 --log-dir var/logs
      a simulated drone; --fc mavlink --fc-url udpout:127.0.0.1:14550 for an autopilot
"""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "drone",
        help="run one drone's software (controller, gear, fail-safe, logger)",
        epilog=EXAMPLES,
    )
    p.add_argument("--id", dest="drone_id", help="drone id (default: from the MAC address)")
    p.add_argument(
        "--broker",
        type=broker_url,
        default="mqtt://127.0.0.1:1883",
        help="mqtt://user@host:port (the password from --broker-password-file)",
    )
    add_broker_password(p)
    p.add_argument(
        "--fc",
        choices=["sim", "mavlink", "uavtalk"],
        default="sim",
        help="flight-controller backend",
    )
    p.add_argument(
        "--fc-url",
        help="autopilot link, e.g. udpout:127.0.0.1:14550 (mavlink) or tcp:127.0.0.1:9000",
    )
    add_signing_key(p)
    add_sim_arguments(p)
    p.add_argument(
        "--onboard-missions",
        action="store_true",
        help="fly missions on board the autopilot (MAVLink AUTO) when every step allows it; "
        "a mission's own 'onboard' option wins",
    )
    p.add_argument(
        "--link-loss",
        choices=["continue", "hold", "rtl"],
        default="continue",
        help="what a running mission does when the broker link is lost (as ArduPilot's GCS "
        "failsafe): fly on (default), hold position, or return home",
    )
    p.add_argument(
        "--link-loss-timeout",
        type=positive_speedup,
        default=5.0,
        help="vehicle seconds without the broker before --link-loss acts (FS_GCS_TIMEOUT)",
    )
    p.add_argument(
        "--set-autopilot-failsafe",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="at connect, turn the autopilot's own link-loss failsafe on (RTL) when it is off "
        "(ArduPilot FS_GCS_ENABLE 1, PX4 NAV_DLL_ACT 2), so a vehicle whose drone software "
        "dies goes home by itself; an operator's own setting is kept. With "
        "--no-set-autopilot-failsafe it is only checked (heartbeats and the pre-flight "
        "checklist say when it is off). MAVLink only",
    )
    p.add_argument("--log-dir", type=Path, help="rotating JSONL logs go here")
    p.add_argument(
        "--state-dir",
        type=Path,
        help="mission reports are kept here (reports.db), so a restart loses none",
    )
    p.add_argument("--gear-dir", type=Path, help="folder with specs.json and sensors.json")
    p.add_argument("--heartbeat-s", type=float, default=5.0, help="heartbeat interval (vehicle s)")
    p.add_argument("--battery-critical", type=float, default=20.0, help="CRITICAL alarm below %%")
    p.add_argument("--battery-rtl", type=float, default=12.0, help="below %%, stop and return home")
    p.add_argument("--battery-land", type=float, default=6.0, help="below %%, land where it is")
    p.add_argument(
        "--sensor-bound", type=parse_bound, action="append", default=[], help="FIELD:LOW:HIGH"
    )
    note_given(p)
    p.set_defaults(func=run)


def inapplicable(args: argparse.Namespace) -> str | None:
    """Why an option given does not apply to ``--fc`` (every such option, one line), or None."""
    wrong = []
    for dest, option in given_options(args).items():
        backends, what = BACKEND_OPTIONS.get(dest, ((args.fc,), ""))
        if args.fc not in backends:
            wrong.append(f"{option} is for --fc {' or '.join(backends)} only ({what})")
    if not wrong:
        return None
    return f"not for --fc {args.fc}: {'; '.join(wrong)}"


def run(args: argparse.Namespace) -> int:
    from dronefleet.drone.config import DroneConfig
    from dronefleet.owner_only import private_umask

    private_umask()  # logs, reports, pictures: the owner's only (issue 25)
    from dronefleet.drone.identity import default_drone_id
    from dronefleet.messaging.topics import TopicError, check_drone_id

    try:
        drone_id = check_drone_id(args.drone_id) if args.drone_id else default_drone_id()
    except TopicError as exc:
        print(f"dronefleet drone: {exc}", file=sys.stderr)
        return 2
    if (why := inapplicable(args)) is not None:
        print(f"dronefleet drone: {why}", file=sys.stderr)
        return 2
    if not 0 <= args.battery_land <= args.battery_rtl <= 100:
        print(
            "dronefleet drone: battery levels must satisfy 0 <= --battery-land <= --battery-rtl"
            f" <= 100 (got {args.battery_land:g} and {args.battery_rtl:g})",
            file=sys.stderr,
        )
        return 2
    config = DroneConfig(
        drone_id=drone_id,
        heartbeat_interval_s=args.heartbeat_s,
        battery_critical_pct=args.battery_critical,
        battery_rtl_pct=args.battery_rtl,
        battery_land_pct=args.battery_land,
        log_dir=args.log_dir,
        gear_dir=args.gear_dir,
        state_dir=args.state_dir,
        onboard_missions=args.onboard_missions,
        link_loss_action=args.link_loss,
        link_loss_timeout_s=args.link_loss_timeout,
    )
    if args.sensor_bound:
        config.sensor_bounds = dict(args.sensor_bound)
    try:
        args.broker = broker_with_password(args.broker, args.broker_password_file)
        args.signing_key = signing_key(args.mavlink_signing_key_file)
    except (OSError, ValueError) as exc:
        print(f"dronefleet drone: {exc}", file=sys.stderr)
        return 2
    if args.signing_key is not None and args.fc != "mavlink":  # from the environment
        print("dronefleet drone: MAVLink signing needs --fc mavlink", file=sys.stderr)
        return 2
    return asyncio.run(_serve(config, args))


async def _serve(config, args: argparse.Namespace) -> int:
    if args.fc != "sim":
        return await _serve_autopilot(config, args)
    from dronefleet.messaging.client import BrokerUnavailable
    from dronefleet.sim.wind import Wind
    from dronefleet.simfleet import SimFleet

    stop = stop_event()
    # The world's own (calm) unless --wind gives this vehicle one.
    wind: dict[str, Any] = {"wind": Wind.from_direction(*args.wind)} if args.wind else {}
    async with SimFleet(speedup=args.speedup, plumes=args.plume) as fleet:
        try:
            app = await fleet.add_drone(
                config, args.broker, home=args.home, battery_pct=args.battery_pct, **wind
            )
        except BrokerUnavailable as exc:
            print(f"dronefleet drone: {exc}", file=sys.stderr)
            return 1
        print(f"drone {config.drone_id} ready on {app.clients['controller'].url}", flush=True)
        await stop.wait()
        await app.stop()
    return 0


async def _serve_autopilot(config, args: argparse.Namespace) -> int:
    """The drone software on a real (or MAVLink/UAVTalk-simulated) autopilot."""
    from dronefleet.drone.app import DroneApp
    from dronefleet.drone.fc.factory import BackendUnavailable, open_flight_controller
    from dronefleet.messaging.client import BrokerUnavailable
    from dronefleet.vehicle.base import FcError

    if not args.fc_url:
        print(f"dronefleet drone: --fc {args.fc} needs --fc-url", file=sys.stderr)
        return 2
    stop = stop_event()
    # A companion computer outlives its autopilot: wait for it with back-off, forever (until
    # stopped), instead of exiting while the autopilot boots or is being replaced (issue 17).
    delay_s = 1.0
    while True:
        try:
            options: dict[str, Any] = {"signing_key": args.signing_key} if args.signing_key else {}
            if args.fc == "mavlink":
                options["set_link_failsafe"] = args.set_autopilot_failsafe
            fc, sensors, camera = await open_flight_controller(args.fc, args.fc_url, **options)
            break
        except (BackendUnavailable, FcError, OSError, TimeoutError) as exc:
            print(
                f"dronefleet drone: waiting for the autopilot at {args.fc_url}: {exc}; "
                f"trying again in {delay_s:g} s",
                file=sys.stderr,
                flush=True,
            )
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(delay_s):
                await stop.wait()
        if stop.is_set():
            return 0
        delay_s = min(delay_s * 2, 30.0)
    if args.plume:
        sensors = {**sensors, "CO2": simulated_co2(fc, args.plume)}
        log.warning(
            "CO2 sensor simulated from --plume (%s); any CO2 the autopilot sends is not used",
            ", ".join(
                f"{lat:g},{lon:g} {peak:g} ppm r {r:g} m" for lat, lon, peak, r in args.plume
            ),
        )
    app = DroneApp(config, fc, args.broker, sensors=sensors, camera=camera)
    try:
        await app.start()
    except BrokerUnavailable as exc:
        print(f"dronefleet drone: {exc}", file=sys.stderr)
        await fc.close()
        return 1
    print(
        f"drone {config.drone_id} ready on {app.clients['controller'].url} via {args.fc}",
        flush=True,
    )
    await stop.wait()
    await app.stop()
    return 0


def simulated_co2(
    fc: FlightController, plumes: list[tuple[float, float, float, float]]
) -> SimulatedSensor:
    """The companion computer's simulated CO2 sensor over ``fc``'s position: the gas field of
    ``plumes`` (background CO2 plus each plume, centred on the ground at home)."""
    from dronefleet.drone.simulated_sensor import SimulatedSensor
    from dronefleet.sim.gasfield import GasField, Plume

    field = GasField(Plume(LLA(lat, lon), peak, radius) for lat, lon, peak, radius in plumes)
    return SimulatedSensor(fc, field.concentration_ppm, name="CO2", unit="ppm", source="--plume")
