"""The list of a mission's pictures (ground/photos): built from the steps the drones reported,
numbered once and for good, and saying why a picture cannot be fetched."""

from __future__ import annotations

import pytest

from dronefleet.errors import Unavailable
from dronefleet.ground.photos.collector import NO_FILE, captures
from dronefleet.ground.photos.store import PhotoStore
from dronefleet.ground.planner.models import Leg, MissionRecord, StepReport


def shot(step: int, lat: float, file: str | None) -> StepReport:
    capture = {"lat": lat, "lon": -8.66, "alt_m": 25.0, "vehicle_time_s": 10.0 + step}
    if file:
        capture["file"] = file
    return StepReport(
        index=step, drone_step=step + 3, command="takepic", measured={"capture": capture}
    )


def record(*legs: Leg) -> MissionRecord:
    return MissionRecord(mission_id="M1", legs=list(legs))


async def test_pictures_are_numbered_once_whatever_order_they_arrive_in(tmp_path):
    a = Leg(
        leg_id="M1.1", drone_id="QUAD_1", reports=[shot(1, 40.1, "var/pictures/QUAD_1_0001.jpg")]
    )
    b = Leg(leg_id="M1.2", drone_id="QUAD_2", reports=[shot(2, 40.2, "C:\\pics\\QUAD_2_0001.jpg")])
    store = PhotoStore(tmp_path)
    await store.register("M1", captures(record(b)))  # the second drone's picture came first
    a.reports.append(shot(5, 40.5, "var/pictures/QUAD_1_0002.jpg"))
    await store.register("M1", captures(record(a, b)))
    await store.register("M1", captures(record(a, b)))  # reported again: nothing new
    listed = await PhotoStore(tmp_path).entries("M1")  # read back from photos.json
    assert [(p.n, p.drone_id, p.step, p.file) for p in listed] == [
        (1, "QUAD_2", 2, "QUAD_2_0001.jpg"),
        (2, "QUAD_1", 1, "QUAD_1_0001.jpg"),
        (3, "QUAD_1", 5, "QUAD_1_0002.jpg"),
    ]
    assert [p.name for p in listed] == ["0001_QUAD_2.jpg", "0002_QUAD_1.jpg", "0003_QUAD_1.jpg"]
    assert not any(p.stored or p.given_up for p in listed)


async def test_a_camera_that_keeps_no_file_is_listed_with_the_reason(tmp_path):
    leg = Leg(leg_id="M1.1", drone_id="AUTO", reports=[shot(1, 40.1, None)])
    [entry] = await PhotoStore(tmp_path).register("M1", captures(record(leg)))
    assert entry.file is None and entry.given_up and entry.error == NO_FILE
    assert (entry.lat, entry.alt_m, entry.vehicle_time_s) == (40.1, 25.0, 11.0)


async def test_every_picture_of_a_distance_trigger_report_is_listed_once(tmp_path):
    taken = [
        {"lat": 40.1 + i / 1000, "lon": -8.66, "alt_m": 25.0, "file": f"T_{i}.jpg"}
        for i in range(3)
    ]
    report = StepReport(
        index=7, drone_step=9, command="camera_trigger", measured={"captures": taken}
    )
    leg = Leg(leg_id="M1.1", drone_id="QUAD_1", reports=[report])
    store = PhotoStore(tmp_path)
    await store.register("M1", captures(record(leg)))
    await store.register("M1", captures(record(leg)))  # reported again: nothing new
    listed = await store.entries("M1")
    assert [(p.n, p.step, p.shot, p.file) for p in listed] == [
        (1, 7, 0, "T_0.jpg"),
        (2, 7, 1, "T_1.jpg"),
        (3, 7, 2, "T_2.jpg"),
    ]


async def test_a_damaged_list_is_refused_with_the_reason_and_left_as_it_was(tmp_path):
    """It was a pydantic error, so a 500 on ``GET .../photos``; and the next report would have
    written a new list over the damaged one."""
    leg = Leg(leg_id="M1.1", drone_id="QUAD_1", reports=[shot(1, 40.1, "QUAD_1_0001.jpg")])
    await PhotoStore(tmp_path).register("M1", captures(record(leg)))
    manifest = tmp_path / "M1" / "photos.json"
    damaged = manifest.read_bytes()[:-20]  # cut short, as a full disk would
    manifest.write_bytes(damaged)
    store = PhotoStore(tmp_path)
    with pytest.raises(Unavailable, match=r"picture list of mission M1 .*cannot be read"):
        await store.entries("M1")
    with pytest.raises(Unavailable):
        await store.register("M1", captures(record(leg)))
    assert manifest.read_bytes() == damaged
