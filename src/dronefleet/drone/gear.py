"""The Gear Manager (seed 3.3.2.3, 4.1.4): drone specs, on-board sensors, the camera.

It knows the drone's physical characteristics (Listing 4.1, ``specs.json``) and the gear on board
(Listing 4.2, ``sensors.json``). Like the seed's, it re-parses both files from a configurable
directory every few seconds so an edit shows up without a restart; a malformed file is logged and
the last good content kept. It answers :class:`GearRequest` queries on ``<id>/gear/in`` with a
:class:`GearReply` on ``<id>/gear/out``, and streams every sensor's readings as telemetry on
``<id>/telemetry/out`` (field ``<sensor>_<unit>``, e.g. ``co2_ppm``) for the Fail-safe System,
the Logger and the ground's Telemetry Analyzer. The pictures the camera wrote are served to the
ground a chunk at a time (``photo`` queries, drone/photo_files.py).
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import logging
import math
import re
from collections.abc import Awaitable, Callable
from dataclasses import asdict
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from dronefleet.clock import Clock
from dronefleet.drone.photo_files import PhotoFiles
from dronefleet.errors import NotFound
from dronefleet.messaging import topics
from dronefleet.messaging.client import QOS_COMMAND, QOS_STREAM, BrokerClient
from dronefleet.messaging.codec import MessageError, decode, decode_object
from dronefleet.messaging.common import validate
from dronefleet.messaging.gear import GearQuery, GearReply, GearRequest
from dronefleet.messaging.status import Telemetry
from dronefleet.messaging.topics import Channel, Direction
from dronefleet.vehicle.payload import Camera, Sensor

log = logging.getLogger(__name__)

SPECS_FILE = "specs.json"
SENSORS_FILE = "sensors.json"
_MAX_SENSOR_DEPTH = 4


def telemetry_field(sensor_name: str, unit: str) -> str:
    """The telemetry field of a sensor's readings: ``("CO2", "ppm")`` -> ``"co2_ppm"``."""
    unit = unit.replace("%", "pct").replace("\u00b5", "u").replace("\u03bc", "u")
    raw = f"{sensor_name}_{unit}".lower()
    return re.sub(r"[^a-z0-9]+", "_", raw).strip("_")


class _Battery(BaseModel):
    model_config = ConfigDict(extra="allow")
    CELL_COUNT: int = Field(ge=1, le=24)
    CAPACITY: float = Field(gt=0, description="mAh")


class _Specs(BaseModel):
    """Listing 4.1; extra keys are kept so operators can describe more than the seed did."""

    model_config = ConfigDict(extra="allow")
    TYPE: str = Field(min_length=1)
    FRAME_SIZE: str | int | float
    BATTERY: _Battery


def check_specs(data: Any) -> dict[str, Any]:
    """Validate a specs file's content (Listing 4.1); :class:`MessageError` with the reason."""
    if not isinstance(data, dict):
        raise MessageError(f"specs must be a JSON object, got {type(data).__name__}")
    validate(_Specs, data)
    return data


def check_sensors(data: Any, depth: int = 0) -> dict[str, Any]:
    """Validate a sensor list (Listing 4.2): an object of model names, grouped in nested objects."""
    if not isinstance(data, dict):
        raise MessageError(f"a sensor list must be a JSON object, got {type(data).__name__}")
    if depth > _MAX_SENSOR_DEPTH:
        raise MessageError(f"sensor groups nest deeper than {_MAX_SENSOR_DEPTH} levels")
    for key, value in data.items():
        if isinstance(value, dict):
            check_sensors(value, depth + 1)
        elif not isinstance(value, str):
            raise MessageError(f"sensor {key!r}: expected a model name or a group, got {value!r}")
    return data


def _default(name: str) -> dict[str, Any]:
    text = resources.files("dronefleet.drone").joinpath("gear_defaults", name).read_bytes()
    return decode_object(text)


class _GearFile:
    """One JSON file, re-read on demand; keeps the last good content when the file goes bad."""

    def __init__(
        self, name: str, gear_dir: Path | None, check: Callable[[Any], dict[str, Any]]
    ) -> None:
        self.name = name
        self.path = None if gear_dir is None else Path(gear_dir) / name
        self.check = check
        self.content: dict[str, Any] = check(_default(name))
        self._last_error: str | None = None

    def reload(self) -> None:
        if self.path is None:
            return
        try:
            raw = self.path.read_bytes()
        except FileNotFoundError:
            self._note(f"{self.path} is missing; using the built-in default")
            self.content = self.check(_default(self.name))
            return
        except OSError as exc:
            self._note(f"cannot read {self.path} ({exc}); keeping the last good content")
            return
        try:
            self.content = self.check(decode(raw))
        except MessageError as exc:
            self._note(f"{self.path} is malformed ({exc}); keeping the last good content")
            return
        if self._last_error is not None:
            log.info("%s is good again", self.path)
        self._last_error = None

    def _note(self, problem: str) -> None:
        # Log each problem once, not every re-read.
        if problem != self._last_error:
            log.warning("gear: %s", problem)
        self._last_error = problem


class GearManager:
    """Serves specs, sensor lists, readings and captures; streams sensor readings as telemetry."""

    def __init__(
        self,
        drone_id: str,
        client: BrokerClient,
        clock: Clock,
        *,
        gear_dir: Path | None,
        sensors: dict[str, Sensor] | None = None,
        camera: Camera | None = None,
        reread_s: float = 10.0,
        sample_hz: float = 2.0,
    ) -> None:
        self.drone_id = topics.check_drone_id(drone_id)
        self.client = client
        self.clock = clock
        self.sensors: dict[str, Sensor] = dict(sensors or {})
        self.camera = camera
        self.photos = PhotoFiles(drone_id)  # the pictures it took, served on request
        self.reread_s = reread_s
        self.sample_hz = sample_hz
        self._specs = _GearFile(SPECS_FILE, gear_dir, check_specs)
        self._sensor_list = _GearFile(SENSORS_FILE, gear_dir, check_sensors)
        self._in_topic = topics.topic(drone_id, Channel.GEAR, Direction.IN)
        self._out_topic = topics.topic(drone_id, Channel.GEAR, Direction.OUT)
        self._telemetry_topic = topics.topic(drone_id, Channel.TELEMETRY, Direction.OUT)
        # Given every sensor sample as read (fields, vehicle seconds), before the broker.
        self.sample_listeners: list[Callable[[dict[str, float], float], Awaitable[None]]] = []
        self._tasks: list[asyncio.Task[None]] = []
        self._failing: set[str] = set()
        self._running = False
        self._subscribed = False

    # -- what it knows -----------------------------------------------------------------------
    @property
    def specs(self) -> dict[str, Any]:
        """The drone's specifications (Listing 4.1), as last read."""
        return self._specs.content

    @property
    def sensor_list(self) -> dict[str, Any]:
        """The gear on board (Listing 4.2), as last read."""
        return self._sensor_list.content

    def reload(self) -> None:
        """Re-read both files now (also done every ``reread_s`` clock seconds)."""
        self._specs.reload()
        self._sensor_list.reload()

    # -- lifecycle ---------------------------------------------------------------------------
    async def start(self) -> None:
        if self._running:
            return
        self._running = True
        self.reload()
        if not self._subscribed:
            await self.client.subscribe(self._in_topic, self._on_request, qos=QOS_COMMAND)
            self._subscribed = True
        self._tasks.append(
            asyncio.create_task(self._reread_loop(), name=f"gear-reread:{self.drone_id}")
        )
        if self.sensors and self.sample_hz > 0:
            self._tasks.append(
                asyncio.create_task(self._sample_loop(), name=f"gear-sample:{self.drone_id}")
            )

    async def stop(self) -> None:
        self._running = False
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        self._tasks.clear()

    # -- queries -----------------------------------------------------------------------------
    async def _on_request(self, _topic: str, payload: bytes) -> None:
        if not self._running:
            return
        reply = await self.answer(payload)
        await self.client.publish(self._out_topic, reply, qos=QOS_COMMAND)

    async def answer(self, payload: bytes) -> GearReply:
        """The reply to one raw request; malformed or unknown requests get ``ok=False`` and why."""
        try:
            data = decode_object(payload)
        except MessageError as exc:
            return self._reply(None, None, error=str(exc))
        raw_id = data.get("request_id")
        request_id = raw_id if isinstance(raw_id, str) and len(raw_id) <= 64 else None
        raw_query = data.get("query")
        query = raw_query if isinstance(raw_query, str) else None
        try:
            request = validate(GearRequest, data)
        except MessageError as exc:
            return self._reply(request_id, query, error=f"bad gear request: {exc}")
        try:
            return await self._serve(request)
        except Exception as exc:  # a sensor or camera driver failing must not kill the manager
            log.exception("gear query %s failed", request.query)
            return self._reply(request_id, query, error=f"{request.query} failed: {exc}")

    async def _serve(self, request: GearRequest) -> GearReply:
        rid, query = request.request_id, request.query.value
        if request.query is GearQuery.SPECS:
            return self._reply(rid, query, specs=self.specs)
        if request.query is GearQuery.SENSORS:
            return self._reply(rid, query, sensors=self.sensor_list)
        if request.query is GearQuery.READING:
            sensor = self._find_sensor(request.sensor)
            if isinstance(sensor, str):
                return self._reply(rid, query, error=sensor)
            reading = asdict(sensor.read())
            if not reading.get("extra"):
                reading.pop("extra", None)
            return self._reply(rid, query, reading=reading)
        if request.query is GearQuery.CAPTURE:
            if self.camera is None:
                return self._reply(rid, query, error=f"drone {self.drone_id} has no camera")
            picture = self.camera.capture()
            if inspect.isawaitable(picture):  # an autopilot's camera confirms asynchronously
                picture = await picture
            self.photos.note(picture)
            return self._reply(rid, query, capture=dict(picture))
        if request.query is GearQuery.PHOTO:  # the picture itself, for the ground (issue 14)
            if not request.photo:
                return self._reply(rid, query, error="name the picture: its capture's file")
            try:
                chunk = await self.photos.chunk(request.photo, request.offset)
            except NotFound as exc:
                return self._reply(rid, query, error=str(exc))
            return self._reply(rid, query, photo=chunk)
        return self._reply(rid, query, error=f"unsupported gear query {query!r}")

    def _find_sensor(self, name: str | None) -> Sensor | str:
        """The sensor called ``name`` (any case), or the reason there is none."""
        connected = ", ".join(sorted(self.sensors)) or "none"
        if not name:
            return f"name a sensor to read; connected: {connected}"
        for key, sensor in self.sensors.items():
            if key.lower() == name.lower():
                return sensor
        return f"no sensor {name!r} on drone {self.drone_id}; connected: {connected}"

    def _reply(self, request_id: str | None, query: str | None, **data: Any) -> GearReply:
        ok = data.get("error") is None
        return GearReply(request_id=request_id, drone_id=self.drone_id, query=query, ok=ok, **data)

    # -- periodic work -----------------------------------------------------------------------
    async def _reread_loop(self) -> None:
        while True:
            await self.clock.sleep(self.reread_s)
            self.reload()

    async def _sample_loop(self) -> None:
        period_s = 1.0 / self.sample_hz
        next_s = self.clock.now() + period_s
        while True:
            await self.clock.sleep(next_s - self.clock.now())
            next_s += period_s
            if next_s < self.clock.now():  # fell behind (slow sensor): don't burst to catch up
                next_s = self.clock.now() + period_s
            fields = self.sample()
            for listener in self.sample_listeners:  # the fail-safe, in process (issue 12)
                try:
                    await listener(fields, self.clock.now())
                except Exception:
                    log.exception("%s: a sensor-sample listener failed", self.drone_id)
            if fields:
                message = Telemetry(
                    drone_id=self.drone_id, vehicle_time_s=self.clock.now(), fields=fields
                )
                await self.client.publish(
                    self._telemetry_topic, message, qos=QOS_STREAM, disposable=True
                )

    def sample(self) -> dict[str, float]:
        """One reading of every sensor as telemetry fields; a failing sensor is left out."""
        fields: dict[str, float] = {}
        for key, sensor in self.sensors.items():
            try:
                reading = sensor.read()
                value = float(reading.value)
                # Where it was read: the Fail-safe places its alarm there (flight telemetry is
                # rate-capped, so its last position may be metres behind a fast vehicle).
                for k in ("lat", "lon", "alt_m"):
                    if isinstance(reading.extra.get(k), int | float) and k not in fields:
                        fields[k] = float(reading.extra[k])
            except Exception as exc:
                if key not in self._failing:
                    log.warning("gear: sensor %s failed (%s); leaving it out", key, exc)
                    self._failing.add(key)
                continue
            if key in self._failing:
                log.info("gear: sensor %s reads again", key)
                self._failing.discard(key)
            if math.isfinite(value):
                fields[telemetry_field(sensor.name, sensor.unit)] = value
        return fields
