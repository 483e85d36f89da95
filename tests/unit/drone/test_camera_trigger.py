"""The distance trigger (drone/camera_trigger.py): every picture it takes is listed.

A picture being taken when the trigger is switched off (the swath's end: ``camera_trigger 0``)
was cancelled half way: the camera had taken it and kept its file, but the trigger never listed
it, so the ground's gallery missed a picture the drone had (seen in CI, on a loaded host, in
tests/integration/planner/test_photos.py: "not within 30 s").
"""

from __future__ import annotations

import asyncio

from dronefleet.clock import WallClock
from dronefleet.drone.camera_trigger import CameraTrigger
from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED

HOME = LLA(40.63, -8.659, 10.0)


class Flying:
    """A vehicle flying north at 10 m per 0.01 wall seconds."""

    def __init__(self) -> None:
        self.clock = WallClock()
        self.north_m = 0.0

    def home(self) -> LLA:
        return HOME

    def position(self) -> LLA:
        return ned_to_lla(NED(self.north_m, 0.0, 0.0), HOME)


async def test_a_picture_being_taken_when_the_trigger_stops_is_listed() -> None:
    fc = Flying()
    taken: list[int] = []
    capturing = asyncio.Event()

    async def camera() -> dict:
        # The Gear Manager takes the picture as the request arrives; its answer takes the way
        # back over the broker. Cancelling the wait for it does not undo the picture.
        taken.append(len(taken) + 1)
        capturing.set()
        file = f"P{len(taken)}.jpg"
        await asyncio.sleep(0.05)
        return {"capture": {"file": file}}

    trigger = CameraTrigger(fc, camera, poll_s=0.001)  # type: ignore[arg-type]
    first = await trigger.set_distance(5.0)
    capturing.clear()
    fc.north_m = 6.0  # a picture falls due
    await asyncio.wait_for(capturing.wait(), 5)  # ... and is being taken
    last = await trigger.set_distance(0.0)  # the swath ends meanwhile
    listed = first["captures"] + last["captures"]
    assert [c["file"] for c in listed] == [f"P{n}.jpg" for n in taken]
    assert len(taken) == 2


async def test_a_picture_due_when_the_trigger_stops_is_taken_and_listed() -> None:
    fc = Flying()
    taken: list[str] = []

    async def camera() -> dict:
        taken.append(f"P{len(taken) + 1}.jpg")
        return {"capture": {"file": taken[-1]}}

    trigger = CameraTrigger(fc, camera, poll_s=3600)  # the loop never looks on its own
    first = await trigger.set_distance(5.0)
    await asyncio.sleep(0)
    fc.north_m = 7.0
    last = await trigger.set_distance(0.0)
    assert (
        [c["file"] for c in first["captures"] + last["captures"]] == taken == ["P1.jpg", "P2.jpg"]
    )
