"""UAVObject definitions (seed 4.1.2.1: "names and definitions for each object are loaded at boot
time, using an XML file for each object"): ids derived from the definition as the generator does,
packing in the generator's field order, and the SI view of scaled fields."""

from __future__ import annotations

import dataclasses

import pytest

from dronefleet.protocols.uavtalk.objects import FieldDef, FieldType, ObjectDef, object_id
from dronefleet.protocols.uavtalk.registry import (
    DefinitionError,
    ObjectRegistry,
    default_registry,
    parse_definitions,
)

REGISTRY = default_registry()

XML = """<xml>
  <object name="TestObject" singleinstance="true" settings="false">
    <description>for tests</description>
    <field name="Mode" units="" type="enum" elements="1" options="Off,On,Auto"/>
    <field name="Count" units="" type="uint16" elements="1"/>
    <field name="Vector" units="m" type="float" elementnames="X,Y,Z"/>
    <field name="Raw" units="" type="int8" elements="4"/>
    <field name="Big" units="" type="int32" elements="1" scale="0.01"/>
    <access gcs="readwrite" flight="readwrite"/>
    <telemetrygcs acked="true" updatemode="manual" period="0"/>
    <telemetryflight acked="false" updatemode="periodic" period="250"/>
    <logging updatemode="manual" period="0"/>
  </object>
</xml>"""


def parse(xml: str = XML) -> ObjectDef:
    (definition,) = parse_definitions(xml)
    return definition


def test_the_hash_reproduces_a_real_dronin_object_id():
    # dRonin's GCSReceiver: one uint16 field "Channel" with 8 elements, single instance, not a
    # setting. Its generated id is 0xCC7E1470; ours must agree byte for byte to talk to a board.
    channel = FieldDef("Channel", FieldType.UINT16, tuple(str(i) for i in range(8)))
    ident = object_id("GCSReceiver", settings=False, single_instance=True, fields=[channel])
    assert ident == 0xCC7E1470


def test_our_definitions_have_stable_ids():
    # Pinned: a GCS built from the same XML files must compute the same ids. If you change a
    # definition on purpose, its id changes (the protocol's intent) and this list with it.
    pinned = {
        "GPSPosition": 0xB6213D8C,
        "AttitudeActual": 0x33DAD5E6,
        "FlightStatus": 0x409AAA22,
        "Waypoint": 0x8D7C93E4,
        "HomeLocation": 0x24009EE2,
        "FlightCommand": 0xE020267E,
    }
    assert {name: REGISTRY[name].id for name in pinned} == pinned
    assert parse().id == parse().id
    assert all(d.id & 1 == 0 for d in REGISTRY)  # the low bit is the metadata object's


@pytest.mark.parametrize(
    "change",
    [
        lambda x: x.replace('name="TestObject"', 'name="TestObjekt"'),
        lambda x: x.replace('singleinstance="true"', 'singleinstance="false"'),
        lambda x: x.replace('settings="false"', 'settings="true"'),
        lambda x: x.replace('name="Count"', 'name="Counter"'),
        lambda x: x.replace('type="uint16"', 'type="int16"'),
        lambda x: x.replace('elements="4"', 'elements="5"'),
        lambda x: x.replace("X,Y,Z", "X,Y,Z,W"),
        lambda x: x.replace("Off,On,Auto", "Off,On,Automatic"),
        lambda x: x.replace("Off,On,Auto", "Off,On"),
    ],
)
def test_changing_what_goes_on_the_wire_changes_the_id(change):
    assert parse(change(XML)).id != parse().id


@pytest.mark.parametrize(
    "change",
    [
        lambda x: x.replace('units="m"', 'units="ft"'),
        lambda x: x.replace("for tests", "something else"),
        lambda x: x.replace('period="250"', 'period="100"'),
        lambda x: x.replace('scale="0.01"', 'scale="0.1"'),
        lambda x: x.replace("X,Y,Z", "A,B,C"),  # element names are not hashed, their count is
    ],
)
def test_presentation_details_do_not_change_the_id(change):
    assert parse(change(XML)).id == parse().id


def test_fields_go_on_the_wire_largest_first_keeping_file_order_among_equals():
    definition = parse()
    assert [f.name for f in definition.fields] == ["Vector", "Big", "Count", "Mode", "Raw"]
    assert definition.size == 12 + 4 + 2 + 1 + 4
    packed = definition.encode({"Vector": {"X": 1.0}, "Count": 0x0102, "Raw": [1, -1]})
    assert packed[:4] == b"\x00\x00\x80\x3f"  # little-endian float 1.0
    assert packed[16:18] == b"\x02\x01"
    assert packed[19:] == b"\x01\xff\x00\x00"


def test_values_round_trip_with_enums_by_name_or_index():
    definition = parse()
    values = {"Mode": "Auto", "Count": 7, "Vector": {"X": 1.5, "Y": -2.0, "Z": 0.25}}
    decoded = definition.decode(definition.encode(values))
    assert decoded == {**values, "Raw": [0, 0, 0, 0], "Big": 0}
    assert definition.decode(definition.encode({"Mode": 1}))["Mode"] == "On"
    assert definition.decode(definition.encode({"Mode": 9}))["Mode"] == 9  # unknown: kept raw


def test_bad_values_are_refused_with_the_field_named():
    definition = parse()
    with pytest.raises(ValueError, match="Mode"):
        definition.encode({"Mode": "Sideways"})
    with pytest.raises(KeyError, match="Nope"):
        definition.encode({"Nope": 1})
    with pytest.raises(ValueError, match="does not fit"):
        definition.encode({"Count": 70000})
    with pytest.raises(ValueError, match="bytes"):
        definition.decode(b"\x00" * 3)


def test_scaled_fields_convert_exactly_to_si():
    gps = REGISTRY["GPSPosition"]
    wire = gps.from_si({"Latitude": 40.6300001, "Longitude": -8.659})
    assert wire == {"Latitude": 406300001, "Longitude": -86590000}
    assert gps.to_si(wire) == {"Latitude": 40.6300001, "Longitude": -8.659}


@pytest.mark.parametrize(
    ("xml", "message"),
    [
        ("<xml><object singleinstance='true' settings='false'/></xml>", "without a name"),
        (XML.replace('type="uint16"', 'type="uint64"'), "type"),
        (XML.replace('singleinstance="true"', 'singleinstance="yes"'), "singleinstance"),
        (XML.replace(' options="Off,On,Auto"', ""), "options"),
        ("<xml><object", "XML|unclosed|no element"),
    ],
)
def test_broken_definitions_are_reported_with_the_object(xml, message):
    with pytest.raises(DefinitionError, match=message):
        parse_definitions(xml, "test.xml")


def test_the_registry_knows_the_seed_objects_and_which_carry_instances():
    for name in (
        "GPSPosition",
        "AttitudeActual",
        "FlightStatus",
        "Waypoint",
        "Accels",
        "FlightBatteryState",
        "HomeLocation",
        "PositionActual",
        "VelocityActual",
    ):
        assert name in REGISTRY
    assert REGISTRY.multi_instance(REGISTRY["Waypoint"].id)
    assert not REGISTRY.multi_instance(REGISTRY["GPSPosition"].id)
    assert not REGISTRY.multi_instance(0x12345678)
    assert REGISTRY["GPSPosition"].flight_period_ms == 200  # 5 Hz, like our GPS
    assert REGISTRY["AttitudeActual"].flight_period_ms == 100  # 10 Hz, as in the seed
    with pytest.raises(KeyError, match="known"):
        REGISTRY["NoSuchObject"]


def test_two_definitions_with_one_id_are_refused():
    definition = parse()
    clone = dataclasses.replace(definition, name="Other")
    object.__setattr__(clone, "id", definition.id)
    registry = ObjectRegistry([definition])
    with pytest.raises(DefinitionError, match="same id"):
        registry.add(clone)
