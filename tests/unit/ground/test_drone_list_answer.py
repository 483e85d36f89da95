"""``GET /api/v1/drones`` sends the Identifier's records as they are (issue 27: validating 1000
of them against ``list[Drone]`` on every request was 18 % of a loaded ground's loop). The JSON
must still be what the response model would have made of them, so the OpenAPI schema stays
true: every field in its declared type, nothing dropped or added."""

from __future__ import annotations

import orjson
from pydantic import TypeAdapter

from dronefleet.ground.fleet import DroneRecord, DroneStatus
from dronefleet.ground.manager.schemas import Drone
from dronefleet.messaging.status import Heartbeat

LIST = TypeAdapter(list[Drone])


def record(drone_id: str, **extra: object) -> DroneRecord:
    hb = Heartbeat.model_validate(
        {
            "drone_id": drone_id,
            "timestamp": 1_700_000_000.25,
            "vehicle_time_s": 12.5,
            "interval_s": 5.0,
            "position": {"lat": 40.63, "lon": -8.659, "alt_m": 10.0, "relative_alt_m": 0.0},
            "home": {"lat": 40.63, "lon": -8.659, "alt_m": 0.0},
            "battery": {"remaining_pct": 90.0, "voltage_v": 16.0},
            "state": "flying",
            "mode": "GUIDED",
            **extra,
        }
    )
    return DroneRecord.first(hb, now=1_700_000_000.5, awake_s=3.0)


def as_the_model_sends(drones: list[dict[str, object]]) -> object:
    valid = LIST.validate_python(drones)
    return orjson.loads(LIST.dump_json(valid, exclude_unset=True))


def test_the_list_sent_is_what_the_response_model_would_send() -> None:
    flying = record("Q1", mission_id="m-1", step_index=3, ground_speed_mps=4.5)
    flying.track(13.0, {"lat": 40.631, "lon": -8.658, "alt_m": 30.0, "relative_alt_m": 20.0})
    lost = record("Q2")
    lost.status = DroneStatus.LOST
    geared = record("Q3")
    geared.specs = {"model": "quad", "max_speed_mps": 10.0}
    geared.sensors = {"camera": {"resolution": [640, 480]}}
    drones = [r.public(2.0) for r in (flying, lost, geared)]

    sent = orjson.loads(orjson.dumps(drones))

    assert sent == as_the_model_sends(drones)
    assert [d["status"] for d in sent] == ["online", "lost", "online"]
    assert sent[0]["position"]["alt_m"] == 30.0  # the telemetry's newer position
    assert "lost_after_s" in sent[0]  # an extra the open model keeps
