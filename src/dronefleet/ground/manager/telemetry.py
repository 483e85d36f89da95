"""``GET /api/v1/telemetry``: any time range of one drone's telemetry, downsampled (seed 3.1.1-2).

``from``/``to`` take Unix seconds or ISO 8601 (``to`` defaults to now, ``from`` to an hour
earlier); ``every`` takes seconds or a duration (``500ms``, ``1s``, ``2m``, ``1h``; default 1 s).
SQLite and InfluxDB give the same answer (see :mod:`dronefleet.ground.telemetry.store`).
"""

import re
from datetime import datetime
from typing import Annotated, Any

from fastapi import APIRouter, Query, Request

from dronefleet.clock import timestamp_s
from dronefleet.ground.manager.context import Viewer, ctx_of
from dronefleet.ground.manager.errors import ApiError, answers
from dronefleet.ground.manager.schemas import Telemetry as TelemetryAnswer
from dronefleet.ground.telemetry.store import FIELD_RE, MAX_BUCKETS, StoreError, TelemetryQuery
from dronefleet.messaging.topics import check_drone_id

router = APIRouter(prefix="/api/v1", tags=["telemetry"], responses=answers(401, 403, 422, 503))

_DURATION = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*(us|ms|s|m|h|d)?\s*$")
_UNIT_US = {"us": 1, "ms": 1_000, "s": 1_000_000, "m": 60_000_000, "h": 3_600_000_000}
_UNIT_US["d"] = 24 * _UNIT_US["h"]


def parse_duration_us(text: str) -> int:
    match = _DURATION.match(text)
    if not match:
        raise ApiError(422, f"every: {text!r} is not a duration (e.g. 1s, 500ms, 2m)")
    value_us = float(match.group(1)) * _UNIT_US[match.group(2) or "s"]
    if not 1_000 <= value_us <= 366 * _UNIT_US["d"]:
        raise ApiError(422, f"every: {text!r} must be between 1ms and 366d")
    return int(value_us)


def parse_time_us(name: str, text: str) -> int:
    try:
        seconds = float(text)
    except ValueError:
        try:
            when = datetime.fromisoformat(text.replace("Z", "+00:00"))
        except ValueError as exc:
            raise ApiError(422, f"{name}: {text!r} is neither Unix seconds nor ISO 8601") from exc
        if when.tzinfo is None:
            raise ApiError(422, f"{name}: {text!r} needs a time zone (e.g. Z or +00:00)") from None
        seconds = when.timestamp()
    if not 0 <= seconds < 1e11:  # NaN fails too
        raise ApiError(422, f"{name}: {text!r} is out of range")
    return round(seconds * 1e6)


@router.get(
    "/telemetry",
    summary="One drone's telemetry over a time range, downsampled",
    response_model=TelemetryAnswer,
)
async def get_telemetry(
    request: Request,
    who: Viewer,
    drone: Annotated[str, Query(min_length=1, max_length=64)],
    fields: Annotated[str | None, Query(max_length=2_000, description="comma-separated")] = None,
    from_: Annotated[str | None, Query(alias="from", max_length=64)] = None,
    to: Annotated[str | None, Query(max_length=64)] = None,
    every: Annotated[str, Query(max_length=32)] = "1s",
) -> dict[str, Any]:
    try:
        check_drone_id(drone)
    except ValueError as exc:
        raise ApiError(422, f"drone: {exc}") from exc
    names = tuple(dict.fromkeys(f.strip() for f in (fields or "").split(",") if f.strip()))
    bad = [f for f in names if not FIELD_RE.match(f)]
    if bad:
        raise ApiError(422, f"fields: invalid field name(s) {', '.join(map(repr, bad))}")
    to_us = parse_time_us("to", to) if to else int(timestamp_s() * 1e6)
    from_us = parse_time_us("from", from_) if from_ else to_us - 3_600_000_000
    every_us = parse_duration_us(every)
    if from_us >= to_us:
        raise ApiError(422, "from must be earlier than to")
    if (to_us - from_us) / every_us > MAX_BUCKETS:
        raise ApiError(422, f"too many buckets: use a larger 'every' (at most {MAX_BUCKETS})")
    query = TelemetryQuery(drone, from_us, to_us, every_us, names)
    try:
        result = await ctx_of(request).telemetry.query(query)
    except StoreError as exc:
        raise ApiError(503, f"telemetry store unavailable: {exc}") from exc
    return result.as_json()
