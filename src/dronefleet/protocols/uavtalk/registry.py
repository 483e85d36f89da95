"""Loading UAVObject definitions from XML: "names and definitions for each object are loaded at
boot time, using an XML file for each object" (seed 4.1.2.1).

The files follow the dRonin/OpenPilot schema: ``<object name singleinstance settings>`` holding
``<field name type units elements|elementnames options>``, ``<access gcs flight>``,
``<telemetrygcs>``, ``<telemetryflight updatemode period>``, ``<logging>`` and ``<description>``.
dronefleet's own files live in ``definitions/``; :func:`default_registry` loads them once.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterable, Iterator
from functools import cache
from pathlib import Path

from dronefleet.errors import InvalidInput
from dronefleet.protocols.uavtalk.objects import FieldDef, FieldType, ObjectDef

DEFINITIONS_DIR = Path(__file__).with_name("definitions")
_XML_TYPES = {t.name.lower(): t for t in FieldType}


class DefinitionError(InvalidInput, ValueError):
    """An XML object definition that cannot be used; says which file and what is wrong."""


def _flag(elem: ET.Element, name: str, where: str) -> bool:
    text = elem.get(name)
    if text not in ("true", "false"):
        raise DefinitionError(f"{where}: attribute {name} must be 'true' or 'false'")
    return text == "true"


def _split(text: str) -> tuple[str, ...]:
    return tuple(p.strip() for p in text.split(",") if p.strip())


def _parse_field(elem: ET.Element, where: str) -> FieldDef:
    name = elem.get("name")
    kind = _XML_TYPES.get(elem.get("type", ""))
    if not name or kind is None:
        raise DefinitionError(f"{where}: field needs a name and a type ({', '.join(_XML_TYPES)})")
    names = _split(elem.get("elementnames", ""))
    if not names:
        count = int(elem.get("elements", "1"))
        if count < 1:
            raise DefinitionError(f"{where}.{name}: elements must be at least 1")
        names = tuple(str(i) for i in range(count))
    options = _split(elem.get("options", ""))
    if kind is FieldType.ENUM and not options:
        raise DefinitionError(f"{where}.{name}: an enum needs options")
    scale = elem.get("scale")
    return FieldDef(
        name,
        kind,
        names,
        named_elements=bool(elem.get("elementnames")),
        options=options,
        units=elem.get("units", ""),
        scale=float(scale) if scale else None,
    )


def parse_definitions(xml_text: str, source: str = "<xml>") -> list[ObjectDef]:
    """Every ``<object>`` in one XML document."""
    try:
        root = ET.fromstring(xml_text)
    except ET.ParseError as exc:
        raise DefinitionError(f"{source}: {exc}") from exc
    objects = [root] if root.tag == "object" else root.findall("object")
    result = []
    for obj in objects:
        name = obj.get("name")
        if not name:
            raise DefinitionError(f"{source}: object without a name")
        where = f"{source}:{name}"
        fields = [_parse_field(f, where) for f in obj.findall("field")]
        if not fields:
            raise DefinitionError(f"{where}: no fields")
        flight = obj.find("telemetryflight")
        gcs = obj.find("telemetrygcs")
        access = obj.find("access")
        result.append(
            ObjectDef(
                name,
                tuple(fields),
                single_instance=_flag(obj, "singleinstance", where),
                settings=_flag(obj, "settings", where),
                description=(obj.findtext("description") or "").strip(),
                flight_update_mode=flight.get("updatemode", "manual")
                if flight is not None
                else "manual",
                flight_period_ms=int(flight.get("period", "0")) if flight is not None else 0,
                acked=gcs is not None and gcs.get("acked") == "true",
                gcs_writable=access is None or access.get("gcs", "readwrite") == "readwrite",
            )
        )
    return result


class ObjectRegistry:
    """The set of UAVObjects both ends know, by name and by id."""

    def __init__(self, definitions: Iterable[ObjectDef] = ()) -> None:
        self.by_name: dict[str, ObjectDef] = {}
        self.by_id: dict[int, ObjectDef] = {}
        for d in definitions:
            self.add(d)

    def add(self, definition: ObjectDef) -> None:
        clash = self.by_id.get(definition.id)
        if clash is not None and clash.name != definition.name:
            raise DefinitionError(f"{definition.name} and {clash.name} hash to the same id")
        self.by_name[definition.name] = definition
        self.by_id[definition.id] = definition

    @classmethod
    def from_directory(cls, folder: Path) -> ObjectRegistry:
        registry = cls()
        for path in sorted(folder.glob("*.xml")):
            for d in parse_definitions(path.read_text(encoding="utf-8"), path.name):
                registry.add(d)
        return registry

    def __getitem__(self, name: str) -> ObjectDef:
        try:
            return self.by_name[name]
        except KeyError:
            raise KeyError(
                f"unknown UAVObject {name!r}; known: {', '.join(sorted(self.by_name))}"
            ) from None

    def __contains__(self, name: object) -> bool:
        return name in self.by_name

    def __iter__(self) -> Iterator[ObjectDef]:
        return iter(self.by_name.values())

    def multi_instance(self, ident: int) -> bool:
        """For :class:`~.framing.FrameParser`: does this object id carry an instance id?"""
        d = self.by_id.get(ident)
        return d is not None and not d.single_instance


@cache
def default_registry() -> ObjectRegistry:
    """dronefleet's own definitions (``definitions/*.xml``)."""
    return ObjectRegistry.from_directory(DEFINITIONS_DIR)
