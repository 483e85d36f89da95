"""UAVObjects: the data containers of the seed's Flight Controller (seed 4.1.2.1).

An :class:`ObjectDef` is one object type as its XML definition describes it (loaded by
:mod:`.registry`). This module packs and unpacks object data and derives each object's 32-bit id
the way the UAVObject generator does:

* fields are ordered by element size, largest first (stable, so equal sizes keep file order);
  that is also their order on the wire (little endian, no padding);
* a shift-add-xor hash ``h = h ^ ((h << 5) + (h >> 2) + v)`` (32 bits) runs over the object
  name's bytes, the settings flag, the single-instance flag, then for each field its name's bytes,
  element count and type code (int8=0 … float=6, enum=7), and for an enum its option names;
* the lowest bit is cleared (it is reserved for the object's metadata object).

So both ends agree on an id only if they agree on the definition; a changed field changes the id
and the objects no longer match, which is the protocol's intent.

dronefleet extension: an optional ``scale`` attribute on a numeric field gives the factor from the
wire value to SI units (e.g. ``1e-7`` for latitude in 1e-7 degrees). It is not hashed.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any


class FieldType(IntEnum):
    """Type codes in the generator's order (they enter the object-id hash)."""

    INT8 = 0
    INT16 = 1
    INT32 = 2
    UINT8 = 3
    UINT16 = 4
    UINT32 = 5
    FLOAT = 6
    ENUM = 7

    @property
    def size(self) -> int:
        return struct.calcsize("<" + _CODES[self])


_CODES = {
    FieldType.INT8: "b",
    FieldType.INT16: "h",
    FieldType.INT32: "i",
    FieldType.UINT8: "B",
    FieldType.UINT16: "H",
    FieldType.UINT32: "I",
    FieldType.FLOAT: "f",
    FieldType.ENUM: "B",
}


@dataclass(frozen=True, slots=True)
class FieldDef:
    name: str
    type: FieldType
    element_names: tuple[str, ...] = ("0",)
    named_elements: bool = False  # element names given in the XML (decode to a dict)
    options: tuple[str, ...] = ()  # enum option names, index = wire value
    units: str = ""
    scale: float | None = None

    @property
    def elements(self) -> int:
        return len(self.element_names)

    @property
    def size(self) -> int:
        return self.type.size * self.elements


def _update(value: int, h: int) -> int:
    return (h ^ (((h << 5) & 0xFFFFFFFF) + (h >> 2) + value)) & 0xFFFFFFFF


def _update_text(text: str, h: int) -> int:
    for byte in text.encode("latin-1"):
        h = _update(byte - 256 if byte > 127 else byte, h)  # the generator hashes signed chars
    return h


def object_id(
    name: str, *, settings: bool, single_instance: bool, fields: Iterable[FieldDef]
) -> int:
    """The 32-bit UAVObject id; ``fields`` must already be in wire (size) order."""
    h = _update_text(name, 0)
    h = _update(int(settings), h)
    h = _update(int(single_instance), h)
    for f in fields:
        h = _update_text(f.name, h)
        h = _update(f.elements, h)
        h = _update(int(f.type), h)
        for option in f.options if f.type is FieldType.ENUM else ():
            h = _update_text(option, h)
    return h & 0xFFFFFFFE


@dataclass(frozen=True)
class ObjectDef:
    """One UAVObject type: its fields in wire order, its id and its update policy."""

    name: str
    fields: tuple[FieldDef, ...]
    single_instance: bool = True
    settings: bool = False
    description: str = ""
    flight_update_mode: str = "manual"  # manual | periodic | onchange | throttled
    flight_period_ms: int = 0
    acked: bool = False  # writes from the GCS expect an ACK
    gcs_writable: bool = True
    id: int = field(init=False)
    _struct: struct.Struct = field(init=False, repr=False)

    def __post_init__(self) -> None:
        ordered = tuple(sorted(self.fields, key=lambda f: -f.type.size))  # sorted() is stable
        object.__setattr__(self, "fields", ordered)
        ident = object_id(
            self.name, settings=self.settings, single_instance=self.single_instance, fields=ordered
        )
        object.__setattr__(self, "id", ident)
        fmt = "<" + "".join(f"{f.elements}{_CODES[f.type]}" for f in ordered)
        object.__setattr__(self, "_struct", struct.Struct(fmt))

    @property
    def size(self) -> int:
        return self._struct.size

    def field(self, name: str) -> FieldDef:
        for f in self.fields:
            if f.name == name:
                return f
        raise KeyError(f"{self.name} has no field {name!r}")

    # -- wire values ---------------------------------------------------------------------------
    def encode(self, values: Mapping[str, Any]) -> bytes:
        """Pack ``values`` (wire units; enums by option name or index); missing fields are 0."""
        unknown = set(values) - {f.name for f in self.fields}
        if unknown:
            raise KeyError(f"{self.name} has no field(s) {', '.join(sorted(unknown))}")
        flat: list[Any] = []
        for f in self.fields:
            flat.extend(_flatten(f, values.get(f.name)))
        try:
            return self._struct.pack(*flat)
        except struct.error as exc:
            raise ValueError(f"{self.name}: a value does not fit its field ({exc})") from exc

    def decode(self, data: bytes) -> dict[str, Any]:
        """Unpack ``data`` (wire units); enums come back as option names."""
        if len(data) != self.size:
            raise ValueError(f"{self.name} is {self.size} bytes, got {len(data)}")
        flat = self._struct.unpack(data)
        out: dict[str, Any] = {}
        i = 0
        for f in self.fields:
            raw = flat[i : i + f.elements]
            i += f.elements
            items = [_enum_name(f, v) for v in raw] if f.type is FieldType.ENUM else list(raw)
            if f.named_elements:
                out[f.name] = dict(zip(f.element_names, items, strict=True))
            else:
                out[f.name] = items[0] if f.elements == 1 else items
        return out

    # -- SI values (the dronefleet ``scale`` extension) ------------------------------------------
    def to_si(self, values: Mapping[str, Any]) -> dict[str, Any]:
        return {k: _scaled(self.field(k).scale, v, 1) for k, v in values.items()}

    def from_si(self, values: Mapping[str, Any]) -> dict[str, Any]:
        return {k: _scaled(self.field(k).scale, v, -1) for k, v in values.items()}


def _scaled(scale: float | None, value: Any, direction: int) -> Any:
    if scale is None:
        return value
    if isinstance(value, dict):
        return {k: _scaled(scale, v, direction) for k, v in value.items()}
    if isinstance(value, list):
        return [_scaled(scale, v, direction) for v in value]
    inverse = 1.0 / scale
    if abs(inverse - round(inverse)) < 1e-9 * inverse:  # 1e-7 -> divide by 10**7: exact decimals
        return value / round(inverse) if direction > 0 else round(value * round(inverse))
    return value * scale if direction > 0 else round(value / scale)


def _enum_name(f: FieldDef, value: int) -> str | int:
    return f.options[value] if value < len(f.options) else value


def _flatten(f: FieldDef, value: Any) -> list[Any]:
    if value is None:
        items: list[Any] = [0] * f.elements
    elif f.named_elements and isinstance(value, Mapping):
        items = [value.get(name, 0) for name in f.element_names]
    elif isinstance(value, list | tuple | bytes | bytearray):
        items = list(value)[: f.elements]
        items += [0] * (f.elements - len(items))
    else:
        items = [value] * f.elements if f.elements > 1 else [value]
    if f.type is FieldType.ENUM:
        items = [_enum_index(f, v) for v in items]
    elif f.type is FieldType.FLOAT:
        items = [float(v) for v in items]
    else:
        items = [int(v) for v in items]
    return items


def _enum_index(f: FieldDef, value: Any) -> int:
    if isinstance(value, bool):
        value = str(value)
    if isinstance(value, str):
        try:
            return f.options.index(value)
        except ValueError:
            raise ValueError(f"{f.name}: {value!r} is not one of {', '.join(f.options)}") from None
    return int(value)
