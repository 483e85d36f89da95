"""A field boundary drawn in Google Earth (KML) read as the planner's area (issue 14).

Google Earth saves a drawn polygon as ``Placemark/Polygon/outerBoundaryIs/LinearRing/coordinates``
(``lon,lat[,alt]`` tuples separated by whitespace), with ``innerBoundaryIs`` rings for holes. The
first Polygon in the file is the area (its holes kept out of); its Placemark's name names the
mission; altitudes are ignored (the planner flies at the height the person sets). Other
polygons are left out with a warning. KMZ (a zipped KML) is refused: unzip it first.

Why defusedxml: a KML file comes from anyone, and XML has an entity language that a file can use
to expand a few bytes into gigabytes (the "billion laughs") or to read local files and URLs
(external entities). defusedxml is the kept library made for exactly this: its parser refuses
any DTD (``forbid_dtd``), so no entity is ever declared, and a file that tries is refused with
the reason. KML needs no DTD. lxml (already installed with pymavlink) would need its own
hardening flags set right to be safe and says less when it refuses; the standard library's
parser expands internal entities.
"""

from __future__ import annotations

from typing import Any
from xml.etree.ElementTree import Element, ParseError

from defusedxml import DefusedXmlException
from defusedxml.ElementTree import fromstring

from dronefleet.ground.planner.bounds import MAX_TOTAL_VERTICES
from dronefleet.ground.planner.files.imported import (
    FileKind,
    ImportedMission,
    MissionFileError,
    mission_spec,
)

#: The area's defaults when a KML says only where (the planner page's defaults).
DEFAULT_SPACING_M = 10.0
DEFAULT_ALTITUDE_M = 15.0


def _local(tag: object) -> str:
    """An element's name without its namespace (KML 2.2, Google's 2.1, or none)."""
    return tag.rsplit("}", 1)[-1] if isinstance(tag, str) else ""


def _children(element: Element, name: str) -> list[Element]:
    return [e for e in element if _local(e.tag) == name]


def _ring(boundary: Element, where: str) -> list[list[float]]:
    """The [lat, lon] corners of a boundary's LinearRing."""
    rings = _children(boundary, "LinearRing")
    coordinates = _children(rings[0], "coordinates") if rings else []
    if not coordinates:
        raise MissionFileError(f"KML: {where} has no LinearRing/coordinates")
    corners = []
    for k, text in enumerate((coordinates[0].text or "").split()):
        parts = text.split(",")
        try:
            lon, lat = float(parts[0]), float(parts[1])
        except (ValueError, IndexError):
            raise MissionFileError(
                f"KML: {where}, coordinate {k + 1} {text[:40]!r} is not lon,lat[,alt]"
            ) from None
        if not (-90 <= lat <= 90 and -180 <= lon <= 180):
            raise MissionFileError(
                f"KML: {where}, coordinate {k + 1} ({lon}, {lat}) is out of range"
            )
        corners.append([lat, lon])
        if len(corners) > MAX_TOTAL_VERTICES:
            raise MissionFileError(f"KML: {where} has over {MAX_TOTAL_VERTICES} corners")
    return corners


def _name_of(root: Element, polygon: Element) -> str:
    """The name of the Placemark holding ``polygon`` (or of the document), if any."""
    for placemark in root.iter():
        if _local(placemark.tag) == "Placemark" and any(e is polygon for e in placemark.iter()):
            names = _children(placemark, "name")
            if names and names[0].text:
                return names[0].text.strip()[:200]
    return ""


def read_kml(data: bytes, name: str = "") -> ImportedMission:
    """The area a KML file draws, as a mission request; :class:`MissionFileError` with why not."""
    if data[:2] == b"PK":
        raise MissionFileError("KML: this is a KMZ (zipped KML); unzip it and import doc.kml")
    try:
        root = fromstring(data, forbid_dtd=True)
    except DefusedXmlException as exc:
        raise MissionFileError(
            f"KML: refused, the file declares a DTD or entities ({exc})"
        ) from None
    except ParseError as exc:
        raise MissionFileError(f"KML: not well-formed XML ({exc})") from None
    if _local(root.tag) != "kml":
        raise MissionFileError(f"KML: the root element is <{_local(root.tag)}>, not <kml>")
    polygons = [e for e in root.iter() if _local(e.tag) == "Polygon"]
    if not polygons:
        raise MissionFileError(
            "KML: no Polygon in the file (draw the field with Google Earth's 'Add Polygon')"
        )
    polygon = polygons[0]
    outer = _children(polygon, "outerBoundaryIs")
    if not outer:
        raise MissionFileError("KML: the Polygon has no outerBoundaryIs")
    area: dict[str, Any] = {
        "polygon": _ring(outer[0], "the outer boundary"),
        "holes": [
            _ring(inner, f"inner boundary {k + 1}")
            for k, inner in enumerate(_children(polygon, "innerBoundaryIs"))
        ],
        "spacing_m": DEFAULT_SPACING_M,
        "altitude_m": DEFAULT_ALTITUDE_M,
    }
    warnings = []
    if len(polygons) > 1:
        warnings.append(f"{len(polygons) - 1} more polygon(s) left out: the first is the area")
    title = _name_of(root, polygon) or name or "imported KML"
    return ImportedMission(
        kind=FileKind.KML, spec=mission_spec({"name": title, "area": area}, "KML"),
        warnings=warnings,
    )  # fmt: skip
