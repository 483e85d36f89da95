"""A loopback stand-in for a Nominatim geocoder: its ``/search`` answers Nominatim's own JSON
(``format=jsonv2``: strings for lat/lon and the bounding box), one place per query, and it keeps
what it was asked (when, the query, the User-Agent)."""

from __future__ import annotations

import json
import time
from urllib.parse import parse_qs, urlsplit

from support.http_stub import HttpStub


class Nominatim(HttpStub):
    """A loopback server answering ``/search`` as Nominatim does (format=jsonv2)."""

    def __init__(self, status: int = 200) -> None:
        self.asked: list[tuple[float, dict[str, list[str]], str]] = []
        self.status = status
        super().__init__(self._answer)

    def _answer(self, path: str, headers: dict[str, str]) -> tuple[int, str, bytes]:
        url = urlsplit(path)
        query = parse_qs(url.query)
        self.asked.append((time.monotonic(), query, headers.get("User-Agent", "")))
        body = json.dumps(
            [
                {
                    "place_id": 1, "licence": "test", "osm_type": "way", "osm_id": 2,
                    "lat": "40.6405", "lon": "-8.6538", "category": "highway",
                    "type": "residential", "place_rank": 26, "importance": 0.1,
                    "addresstype": "road", "name": "Rua de Aveiro",
                    "display_name": f"{query['q'][0]}, Aveiro, Portugal",
                    "boundingbox": ["40.6400", "40.6410", "-8.65455", "-8.65305"],
                }
            ]
            if url.path == "/search" and self.status == 200
            else {"error": "boom"}
        ).encode()  # fmt: skip
        return self.status, "application/json", body
