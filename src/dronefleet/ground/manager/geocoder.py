"""Addresses to places through a Nominatim-compatible geocoder (``--geocoder URL``, issue 14).

The ground asks the geocoder, never the page: the web app's Content-Security-Policy stays
``connect-src 'self'``, and the operator's searches leave from one known place. Nominatim's usage
policy is kept: a User-Agent naming the software, at most one request a second (later ones wait
their turn), answers cached. The answer is Nominatim's ``jsonv2`` list (``lat``/``lon`` as
strings, ``boundingbox`` as [south, north, west, east] strings), read into a model; anything else
is a refusal with the reason. httpx (already the ground's HTTP client) rather than geopy's
geocoders, whose Nominatim client is synchronous unless aiohttp is added.
"""

from __future__ import annotations

import asyncio
import time
from collections import OrderedDict
from enum import StrEnum

import httpx
from pydantic import BaseModel, Field, ValidationError

from dronefleet import __version__
from dronefleet.errors import NoAnswer, Unavailable

MIN_INTERVAL_S = 1.0  # Nominatim's usage policy: an absolute maximum of one request per second
TIMEOUT_S = 10.0
MAX_ANSWER_BYTES = 1_000_000
RESULTS = 5
CACHED = 256


class PlaceKind(StrEnum):
    COORDINATES = "coordinates"
    DRONE = "drone"
    MISSION = "mission"
    ADDRESS = "address"


class Place(BaseModel):
    """A search result the map centres on: a point, and the box to show when it is an area."""

    kind: PlaceKind
    label: str
    lat: float = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)
    bounds: list[float] | None = Field(
        default=None, description="[south, west, north, east] in degrees, to fit the map to"
    )


class _Found(BaseModel):
    """One Nominatim result, as much of it as a map needs."""

    lat: float = Field(ge=-90, le=90)
    lon: float = Field(ge=-180, le=180)
    display_name: str = Field(default="", max_length=1000)
    boundingbox: list[float] | None = Field(default=None, min_length=4, max_length=4)


class GeocoderError(Unavailable):
    """The geocoder answered, but not with places (an error status, not Nominatim's JSON)."""


class Geocoder:
    """``await Geocoder(url).search("Rua ..., Aveiro")`` → up to :data:`RESULTS` places."""

    def __init__(self, url: str, *, min_interval_s: float = MIN_INTERVAL_S) -> None:
        base = url.rstrip("/")
        self.url = base if base.endswith("/search") else f"{base}/search"
        self.min_interval_s = min_interval_s
        self._client = httpx.AsyncClient(
            timeout=TIMEOUT_S,
            headers={"User-Agent": f"dronefleet/{__version__} (ground station map search)"},
            follow_redirects=False,
        )
        self._turn = asyncio.Lock()
        self._last_s = -float("inf")
        self._cache: OrderedDict[str, list[Place]] = OrderedDict()

    async def search(self, text: str) -> list[Place]:
        key = " ".join(text.lower().split())
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        async with self._turn:  # one request at a time, a second apart
            wait_s = self._last_s + self.min_interval_s - time.monotonic()
            if wait_s > 0:
                await asyncio.sleep(wait_s)
            try:
                places = await self._ask(text)
            finally:
                self._last_s = time.monotonic()
        self._cache[key] = places
        if len(self._cache) > CACHED:
            self._cache.popitem(last=False)
        return places

    async def _ask(self, text: str) -> list[Place]:
        params = {"q": text, "format": "jsonv2", "limit": str(RESULTS)}
        try:
            async with self._client.stream("GET", self.url, params=params) as response:
                body = bytearray()
                async for chunk in response.aiter_bytes():
                    body += chunk
                    if len(body) > MAX_ANSWER_BYTES:
                        raise GeocoderError(f"the geocoder's answer is over {MAX_ANSWER_BYTES} B")
        except httpx.TimeoutException as exc:
            raise NoAnswer(f"the geocoder did not answer within {TIMEOUT_S:g} s") from exc
        except httpx.HTTPError as exc:
            raise Unavailable(f"the geocoder at {self.url} cannot be reached: {exc}") from exc
        if response.status_code != 200:
            raise GeocoderError(f"the geocoder answered HTTP {response.status_code}")
        return _places(bytes(body))

    async def close(self) -> None:
        await self._client.aclose()


def _places(body: bytes) -> list[Place]:
    from pydantic import TypeAdapter

    try:
        found = TypeAdapter(list[_Found]).validate_json(body)
    except ValidationError as exc:
        raise GeocoderError(f"the geocoder's answer is not Nominatim's JSON: {exc}") from None
    places = []
    for item in found[:RESULTS]:
        box = item.boundingbox
        bounds = [box[0], box[2], box[1], box[3]] if box else None  # to [s, w, n, e]
        label = item.display_name or f"{item.lat:.5f}, {item.lon:.5f}"
        places.append(
            Place(kind=PlaceKind.ADDRESS, label=label, lat=item.lat, lon=item.lon, bounds=bounds)
        )
    return places
