"""A mission's timeline and progress (issue 29): what replacement and collaboration did, or that
they were off; a stall and its end; the time left estimated from where a drone is."""

from __future__ import annotations

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from dronefleet.ground.planner.coverage import AreaSpec
from dronefleet.ground.planner.eta import EtaJob, remaining_s, steps_left
from dronefleet.ground.planner.models import (
    EventKind,
    Expansion,
    LatLon,
    Leg,
    MissionRecord,
    MissionState,
    StepReport,
)
from dronefleet.ground.planner.options import RecordOptions
from dronefleet.ground.planner.progress_view import mission_progress
from dronefleet.ground.planner.timeline import events_of, note
from dronefleet.messaging.commands import AlarmLevel
from dronefleet.messaging.common import Position
from dronefleet.messaging.status import Alarm

HOME = LLA(40.63, -8.658, 5.0)
AREA = AreaSpec(polygon=[(40.63, -8.658), (40.6303, -8.658), (40.6303, -8.6576)], spacing_m=10)


def co2_alarm(drone: str = "Q1", t: float = 42.0) -> Alarm:
    return Alarm(
        drone_id=drone, level="OUT_MEASURE", message="co2_ppm 1450 above its high bound 1000",
        position=Position(lat=HOME.lat, lon=HOME.lon, alt_m=15.0), vehicle_time_s=t,
        reading={"field": "co2_ppm", "value": 1450, "low": None, "high": 1000},
    )  # fmt: skip


def alarm_data(record: MissionRecord, alarm: Alarm) -> dict:
    return {**alarm.model_dump(mode="json"), "mission_id": record.mission_id}


def test_an_expansion_says_which_alarm_grew_the_area_and_which_drones_were_called():
    record = MissionRecord(mission_id="M1", area=AREA)
    alarm = co2_alarm()
    record.alarms.append(alarm)
    assert note(record, "alarm", alarm_data(record, alarm))
    assert record.events[-1].text == (
        "co2 alarm on Q1: co2_ppm 1450 above its high bound 1000; the area is grown around it"
    )
    expansion = Expansion(
        drone_id="Q1", alarm_vehicle_s=42.0, centre=LatLon(lat=HOME.lat, lon=HOME.lon),
        area_factor=2.0, joined=["Q2", "Q3"], waypoints=30,
    )  # fmt: skip
    record.expansions.append(expansion)
    assert note(record, "expansion", {"mission_id": "M1", **expansion.model_dump(mode="json")})
    event = record.events[-1]
    assert event.kind is EventKind.EXPANSION and event.drones == ["Q2", "Q3"]
    assert event.text == (
        "co2 alarm on Q1 (co2_ppm 1450 above its high bound 1000): area expanded 2 times"
        " (30 waypoints), drones Q2, Q3 called"
    )


def test_switched_off_replacement_and_collaboration_say_they_did_nothing():
    off = RecordOptions(replacement=False, collaboration=False)
    record = MissionRecord(mission_id="M2", area=AREA, options=off)
    note(record, "alarm", alarm_data(record, co2_alarm()))
    critical = co2_alarm().model_copy(
        update={"level": AlarmLevel.CRITICAL, "message": "battery 14%"}
    )
    note(record, "alarm", alarm_data(record, critical))
    assert [e.text for e in record.events] == [
        "co2 alarm on Q1: co2_ppm 1450 above its high bound 1000; collaboration is off: the area"
        " stays as planned",
        "CRITICAL alarm on Q1: battery 14%; replacement is off: nobody takes over",
    ]
    # Another mission's alarm, and a WARNING, are not this mission's events.
    assert not note(record, "alarm", {**alarm_data(record, critical), "mission_id": "M3"})
    assert not note(record, "alarm", {**alarm_data(record, critical), "level": "WARNING"})


def test_a_failed_expansion_is_in_the_timeline_although_nobody_announced_it():
    record = MissionRecord(mission_id="M4", area=AREA)
    record.alarms.append(co2_alarm())
    centre = LatLon(lat=HOME.lat, lon=HOME.lon)
    record.expansions.append(
        Expansion(drone_id="Q1", alarm_vehicle_s=42.0, centre=centre, error="no drone free")
    )
    (event,) = events_of(record)
    assert event.text.endswith("area not expanded: no drone free")
    assert event.at == record.alarms[0].timestamp


def test_a_stall_its_end_and_the_missions_end_are_noted_once_each():
    record = MissionRecord(mission_id="M5")
    states = ["running", "stalled", "stalled", "handed_over", "completed", "completed"]
    for state in states:
        data = {"mission_id": "M5", "state": state, "error": "Q1 lost", "waypoints": 4,
                "waypoints_reached": 4}  # fmt: skip
        note(record, "mission", data)
    assert [e.text for e in record.events] == [
        "stalled: Q1 lost",
        "running again",
        "completed: 4/4 waypoints",
    ]
    # Ended but not announced yet: the progress view says so already.
    ended = MissionRecord(mission_id="M6", state=MissionState.FAILED, error="Q1 failed")
    ended.ended_at = 100.0
    assert [(e.text, e.at) for e in events_of(ended)] == [("failed: Q1 failed", 100.0)]


def square_steps() -> list[dict]:
    steps: list[dict] = []
    for n, e in [(40, 0), (40, 40), (0, 40), (0, 0)]:
        at = ned_to_lla(NED(n, e), HOME)
        steps += [
            {"command": "navigate", "lat": at.lat, "lon": at.lon, "altitude_delta": 10},
            {"command": "wait_for_flight"},
        ]
    return steps


def test_the_time_left_falls_as_the_drone_gets_on_and_a_leg_in_flight_keeps_its_goal():
    record = MissionRecord(mission_id="M7", work=square_steps())
    leg = Leg(leg_id="M7.1", drone_id="Q1", indices=list(range(8)), state="running")
    record.legs.append(leg)
    left = []
    for done in range(0, 8, 2):
        here = ned_to_lla(NED(*[(0, 0), (40, 0), (40, 40), (0, 40)][done // 2]), HOME)
        here = LLA(here.lat, here.lon, HOME.alt_m + 10)
        # Its navigate reported: flying to the point, the navigate is kept for the estimate.
        leg.reports.append(StepReport(index=done, drone_step=done, command="navigate"))
        steps = steps_left(record, leg)
        assert steps[0] == record.work[done] and len(steps) == 8 - done
        job = EtaJob(steps, here, HOME, True, 90.0, None, None, None, 0.0)
        (seconds,) = remaining_s([job])
        left.append(seconds)
        leg.reports.append(StepReport(index=done + 1, drone_step=done + 1, command="wait"))
        record.done.update({done: "Q1", done + 1: "Q1"})
    assert left == sorted(left, reverse=True) and left[-1] > 0, left
    assert 40 / 10 < left[-1] < left[0] < 60, left  # 40 m legs at up to 10 m/s
    view = mission_progress(record, {})
    (drone,) = view["progress"]
    assert drone["share"] == 1.0 and drone["waypoints_reached"] == 4
    assert drone["current"] is None and drone["eta_s"] is None  # running, nothing left to fly


def test_a_handover_splits_the_shares_so_each_drone_done_with_its_part_shows_it_full():
    record = MissionRecord(mission_id="M8", work=square_steps())
    first = Leg(leg_id="M8.1", drone_id="Q1", indices=list(range(8)), state="replaced")
    second = Leg(leg_id="M8.2", drone_id="Q2", indices=list(range(4, 8)), state="running")
    record.legs += [first, second]
    record.done.update({i: "Q1" for i in range(4)})  # Q1 flew two waypoints, then handed over
    record.done.update({4: "Q2", 5: "Q2"})  # Q2 one of the two left
    q1, q2 = mission_progress(record, {})["progress"]
    assert (q1["waypoints_reached"], q1["waypoints"], q1["share"]) == (2, 2, 1.0)
    assert (q2["waypoints_reached"], q2["waypoints"], q2["share"]) == (1, 2, 0.5)
