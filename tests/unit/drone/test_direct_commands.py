"""Which direct commands a drone flying a mission obeys (drone/direct_commands.py, issue 26)."""

from __future__ import annotations

import pytest

from dronefleet.drone.direct_commands import (
    FlyingMission,
    MissionBusy,
    mind_the_mission,
    parse_with_force,
)
from dronefleet.messaging.codec import MessageError


class Gate:
    def __init__(self, flying: FlyingMission | None) -> None:
        self.mission = flying
        self.yielded: list[tuple[str, str]] = []

    def flying(self) -> FlyingMission | None:
        return self.mission

    async def yield_to(self, command: str, note: str) -> None:
        self.yielded.append((command, note))


MISSION = FlyingMission("M1", 11, 39)


def test_force_is_read_on_every_guarded_command_and_must_be_a_boolean():
    request, forced = parse_with_force({"command": "takeoff", "value": 5, "force": True})
    assert (request.command, request.value, forced) == ("takeoff", 5, True)
    assert parse_with_force({"command": "navigate", "lat": 1, "lon": 2})[1] is False
    assert parse_with_force({"command": "disarm", "force": True})[1] is True  # the model's own
    with pytest.raises(MessageError, match="force: must be true or false"):
        parse_with_force({"command": "altitude", "value": 3, "force": "yes"})
    with pytest.raises(MessageError, match="force"):  # land has no force to give
        parse_with_force({"command": "land", "force": True})
    with pytest.raises(MessageError, match="value"):  # the message's own error comes first
        parse_with_force({"command": "changeN", "value": "north", "force": True})


@pytest.mark.parametrize("command", ["takeoff", "navigate", "changeN", "altitude", "disarm"])
async def test_a_guarded_command_is_refused_in_one_sentence_unless_forced(command):
    data = {"command": command, "sender": "alice"}
    data |= {"lat": 1.0, "lon": 2.0} if command == "navigate" else {}
    data |= {"value": 3} if command in ("changeN", "altitude") else {}
    request, _ = parse_with_force(data)
    gate = Gate(MISSION)
    with pytest.raises(MissionBusy) as refused:
        await mind_the_mission(gate, "QUAD_1", request, forced=False)
    assert str(refused.value) == (
        "QUAD_1 is flying mission M1 (step 12 of 40): pause or abort it first, or force"
    )
    assert gate.yielded == []
    await mind_the_mission(gate, "QUAD_1", request, forced=True)
    assert gate.yielded == [(command, "forced by alice")]
    await mind_the_mission(Gate(None), "QUAD_1", request, forced=False)  # no mission: obeyed


@pytest.mark.parametrize("command", ["land", "rtl"])
async def test_a_safety_command_pauses_the_mission_and_is_obeyed(command):
    request, _ = parse_with_force({"command": command})
    gate = Gate(MISSION)
    await mind_the_mission(gate, "QUAD_1", request, forced=False)
    assert gate.yielded == [(command, "sent by an unnamed client")]


@pytest.mark.parametrize("command", ["arm", "takepic", "rebuildtelemetry"])
async def test_commands_that_do_not_move_the_vehicle_leave_the_mission_alone(command):
    request, _ = parse_with_force({"command": command})
    gate = Gate(MISSION)
    await mind_the_mission(gate, "QUAD_1", request, forced=False)
    assert gate.yielded == []


@pytest.mark.parametrize("mode", ["HOLD", "LAND", "RTL"])
async def test_a_mode_that_stops_or_lands_pauses_the_mission_and_is_obeyed(mode):
    request, _ = parse_with_force({"command": "mode", "value": mode, "sender": "bob"})
    gate = Gate(MISSION)
    await mind_the_mission(gate, "QUAD_1", request, forced=False)
    assert gate.yielded == [(f"mode {mode}", "sent by bob")]


async def test_guided_mid_mission_is_refused_unless_forced():
    request, forced = parse_with_force({"command": "mode", "value": "GUIDED", "force": True})
    assert forced is True
    gate = Gate(MISSION)
    with pytest.raises(MissionBusy, match="pause or abort it first, or force"):
        await mind_the_mission(gate, "QUAD_1", request, forced=False)
    await mind_the_mission(gate, "QUAD_1", request, forced=True)
    assert gate.yielded == [("mode GUIDED", "forced by an unnamed client")]
