"""Coordinates as people type them: decimal (``40.63, -8.66``) or DMS (``40°37'48"N 8°39'36"W``).

The map pages' search box (issue 14) sends what was typed; this says whether it is a position and
which. Strict on purpose: a place on the map that a drone may be sent to must never be a guess.
geopy's ``Point.from_string`` was tried and rejected for that reason: it reads
``40 37 48 N 8 39 36 W`` as 39°N 36°W and ``40.63,-8.66,12`` as 8.66°S, without a word.

Accepted: two numbers (latitude first) separated by a comma, a semicolon or a space; each may be
degrees, degrees and minutes, or degrees, minutes and seconds, marked with ``°`` ``'`` ``"`` (or
their typographic forms), or plain numbers when a hemisphere letter (N, S, E, W, before or after)
ends each one. Hemisphere letters say which is the latitude, so ``8.66W 40.63N`` works too.
"""

from __future__ import annotations

import re

from dronefleet.errors import InvalidInput

# Typographic primes and quotes (U+2032, U+2019, U+2018; U+2033, U+201D, U+201C) and the
# masculine ordinal (U+00BA) that keyboards give for ' " and °.
_PRIMES = str.maketrans(
    {
        "\u2032": "'",
        "\u2019": "'",
        "\u2018": "'",
        "\u2033": '"',
        "\u201d": '"',
        "\u201c": '"',
        "\u00ba": "°",
    }
)
_TOKEN = re.compile(
    r"\s*(?:(?P<num>[-+]?\d+(?:\.\d+)?)|(?P<unit>[°'\"])|(?P<hemi>[NSEWnsew])|(?P<sep>[,;]))"
)
_UNIT_RANK = {"°": 0, "'": 1, '"': 2}

Token = tuple[str, str]  # (kind, text)


class CoordinateError(InvalidInput, ValueError):
    """Text that is a pair of coordinates, but an impossible one (latitude 91, minutes 75)."""


def parse_coordinates(text: str) -> tuple[float, float] | None:
    """``(lat, lon)`` in degrees for a typed position; None when ``text`` is not coordinates.

    Raises :class:`CoordinateError` for a well-formed pair out of range, with the reason."""
    tokens = _tokens(text.translate(_PRIMES).replace("''", '"'))
    if tokens is None or not any(kind == "num" for kind, _ in tokens):
        return None
    parts = _split(tokens)
    if parts is None:
        return None
    values: list[tuple[float, str | None]] = []
    for part in parts:
        value = _coordinate(part)
        if value is None:
            return None
        values.append(value)
    return _assign(values)


def _tokens(text: str) -> list[Token] | None:
    out: list[Token] = []
    pos, text = 0, text.strip()
    while pos < len(text):
        match = _TOKEN.match(text, pos)
        if match is None or match.end() == pos:
            return None  # something that is not part of a coordinate: a name, an address
        kind = match.lastgroup or ""
        out.append((kind, match.group(kind)))
        pos = match.end()
    return out


def _split(tokens: list[Token]) -> list[list[Token]] | None:
    """The tokens of each of the two coordinates (separators dropped), or None."""
    hemis = [i for i, (kind, _) in enumerate(tokens) if kind == "hemi"]
    seps = [i for i, (kind, _) in enumerate(tokens) if kind == "sep"]
    if len(seps) > 1 or (hemis and len(hemis) != 2):
        return None
    if hemis:  # each coordinate ends (or begins) with its hemisphere letter
        cut = hemis[1] if hemis[0] == 0 else hemis[0] + 1
        parts = [tokens[:cut], tokens[cut:]]
    elif seps:
        parts = [tokens[: seps[0]], tokens[seps[0] + 1 :]]
    else:  # spaces only: a new coordinate starts at a number with no smaller unit before it
        parts = _split_by_units(tokens)
    parts = [[t for t in part if t[0] != "sep"] for part in parts]
    return parts if len(parts) == 2 and all(parts) else None


def _split_by_units(tokens: list[Token]) -> list[list[Token]]:
    nums = [i for i, (kind, _) in enumerate(tokens) if kind == "num"]
    if all(kind == "num" for kind, _ in tokens):
        return [[t] for t in tokens]  # "40.63 -8.66": two plain numbers
    for i in nums[1:]:
        unit = tokens[i + 1][1] if i + 1 < len(tokens) and tokens[i + 1][0] == "unit" else None
        if unit == "°":
            return [tokens[:i], tokens[i:]]
    return [tokens]


def _coordinate(part: list[Token]) -> tuple[float, str | None] | None:
    """One coordinate's signed degrees and its hemisphere letter (upper case), or None."""
    hemi = next((text.upper() for kind, text in part if kind == "hemi"), None)
    body = [t for t in part if t[0] != "hemi"]
    numbers: list[tuple[float, int]] = []  # (value, rank: 0 degrees, 1 minutes, 2 seconds)
    i = 0
    while i < len(body):
        kind, text = body[i]
        if kind != "num":
            return None
        rank = len(numbers)
        if i + 1 < len(body) and body[i + 1][0] == "unit":
            rank = _UNIT_RANK[body[i + 1][1]]
            i += 1
        if rank != len(numbers) or rank > 2:
            return None  # units out of order ("30' 40°") or a fourth number
        numbers.append((float(text), rank))
        i += 1
    if not numbers or (len(numbers) > 1 and hemi is None and not _marked(body)):
        return None  # "40 37 48 8 39 36": which numbers go together is a guess
    return _degrees([v for v, _ in numbers], hemi), hemi


def _marked(body: list[Token]) -> bool:
    return any(kind == "unit" for kind, _ in body)


def _degrees(values: list[float], hemi: str | None) -> float:
    degrees, *rest = values
    sign = -1.0 if degrees < 0 or str(values[0]).startswith("-") else 1.0
    if rest and degrees != int(degrees):
        raise CoordinateError(f"{degrees:g}° with minutes: the degrees must be whole")
    for value, name in zip(rest, ("minutes", "seconds"), strict=False):
        if not 0 <= value < 60:
            raise CoordinateError(f"{value:g} {name}: must be from 0 to under 60")
        if name == "minutes" and len(rest) == 2 and value != int(value):
            raise CoordinateError(f"{value:g} minutes with seconds: the minutes must be whole")
    magnitude = abs(degrees) + sum(v / 60.0**k for k, v in enumerate(rest, start=1))
    if hemi in ("S", "W"):
        if sign < 0:
            raise CoordinateError(f"-{magnitude:g}{hemi}: a minus sign and {hemi} say it twice")
        sign = -1.0
    return sign * magnitude


def _assign(values: list[tuple[float, str | None]]) -> tuple[float, float]:
    (a, ha), (b, hb) = values
    axis = {"N": "lat", "S": "lat", "E": "lon", "W": "lon"}
    if ha and hb and axis[ha] == axis[hb]:
        raise CoordinateError(f"two {'latitudes' if axis[ha] == 'lat' else 'longitudes'} given")
    lat, lon = (b, a) if ha and axis[ha] == "lon" else (a, b)
    if not -90 <= lat <= 90:
        raise CoordinateError(f"latitude {lat:g} is beyond ±90°")
    if not -180 <= lon <= 180:
        raise CoordinateError(f"longitude {lon:g} is beyond ±180°")
    return lat, lon
