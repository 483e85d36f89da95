"""Our missions on ArduPilot Copter SITL beside the same waypoints flown as a plain AUTO mission.

For each case — a step mission (5 legs of 100 m at 20 m, ended as the planner ends every mission:
home by RTL, issue 28) with the planner's defaults and with the
seed's strategy, on board; an area of 120 x 80 m at 20 m spacing with photos (one drone, and split
over two) — this flies the mission the way a user would (Mosquitto, ``dronefleet ground``,
``dronefleet drone --fc mavlink`` per vehicle, the REST API), and prints:

- our time: vehicle seconds (SITL's ``time_boot_ms``) from the leg's start to its end;
- our estimate: what ``POST /api/v1/missions/preview`` said before the flight (time, battery);
- the reference: the same waypoints uploaded by pymavlink as an AUTO mission (take-off, the
  waypoints, RTL: the planner's default end), from the arm command until ArduPilot disarms;
- the ratios, the battery used, and the end state.

    ARDUPILOT_SITL=../shared/ardupilot .venv/bin/python bench/ardupilot_parity.py [--cases ...]
        [--twice]   # each case flown again on a fresh pack, estimated with the measured draw
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from pymavlink import mavutil

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from dronefleet.geo.ned import ned_to_lla
from dronefleet.geo.types import LLA, NED
from support.sitl import EKF_READY_S, Ground, fly_drone, ground_stack, unpack

ALT_M = 20.0
STEP_LEGS = [(100, 0), (100, 100), (0, 100), (0, 0), (50, 50)]
AREA = [(20, 0), (100, 0), (100, 120), (20, 120)]  # 80 m north x 120 m east
CAMERA = {"CAM1_TYPE": 1}


def step_spec(home: LLA, **options: Any) -> dict[str, Any]:
    steps: list[dict[str, Any]] = []
    for n, e in STEP_LEGS:
        p = ned_to_lla(NED(n, e, 0), home)
        steps += [
            {"command": "navigate", "lat": p.lat, "lon": p.lon, "altitude_delta": ALT_M},
            {"command": "wait_for_flight"},
        ]
    return {"name": "step", "steps": steps, "options": options}


def area_spec(home: LLA, fly_through: bool = False, **options: Any) -> dict[str, Any]:
    corners = [ned_to_lla(NED(n, e, 0), home) for n, e in AREA]
    area = {
        "polygon": [[c.lat, c.lon] for c in corners],
        "spacing_m": 20,
        "altitude_m": ALT_M,
        "angle_deg": 90,
        "action": "takepic",
        "fly_through": fly_through,
    }
    return {"name": "area", "area": area, "options": options}


def survey_spec(home: LLA, **options: Any) -> dict[str, Any]:
    """The area photographed on the move (pictures by distance along each line)."""
    return area_spec(home, fly_through=True, **options)


CASES: dict[str, tuple[Any, int, dict[str, Any]]] = {
    "step, defaults": (step_spec, 1, {}),
    "step, seed": (step_spec, 1, {"strategy": "seed"}),
    "step, on board": (step_spec, 1, {"onboard": True}),
    "area, one drone, seed": (area_spec, 1, {"strategy": "seed"}),
    "area, one drone, defaults": (area_spec, 1, {}),
    "area, two drones, defaults": (area_spec, 2, {}),
    "area, on board": (area_spec, 1, {"onboard": True}),
    "area, on board, fly-through": (survey_spec, 1, {"onboard": True}),
}


def waypoints_of(work: list[dict[str, Any]]) -> list[tuple[float, float]]:
    return [(s["lat"], s["lon"]) for s in work if s.get("command") == "navigate"]


def fly_ours(ground: Ground, spec: dict[str, Any], drones: list[str]) -> dict[str, Any]:
    spec = {**spec, "drones": drones}
    preview = ground.api("POST", "/api/v1/missions/preview", json=spec).json()
    created = ground.api("POST", "/api/v1/missions?start=true", json=spec).json()
    battery0 = {d: ground.drone(d)["battery"]["remaining_pct"] for d in drones}
    mission = ground.wait_ended(created["mission_id"], timeout_s=900)
    record = ground.api("GET", f"/api/v1/missions/{created['mission_id']}").json()
    legs = record.get("legs") or []
    times = [
        (leg.get("ended_vehicle_s") or 0) - (leg.get("started_vehicle_s") or 0) for leg in legs
    ]
    used = {d: battery0[d] - ground.drone(d)["battery"]["remaining_pct"] for d in drones}
    est = preview.get("drones") or []
    return {
        "state": mission["state"],
        "error": mission.get("error"),
        "time_s": max(times) if times else float("nan"),
        "estimate_s": max((d.get("duration_s") or 0) for d in est) if est else float("nan"),
        "estimate_battery": max((d.get("battery_used_pct") or 0) for d in est) if est else None,
        "battery_used": max(used.values()),
        "work": preview.get("steps") or spec.get("steps") or [],
    }


def fly_auto(url: str, home: LLA, waypoints: list[tuple[float, float]]) -> dict[str, Any]:
    """The reference: pymavlink uploads take-off, the waypoints and RTL, arms, starts AUTO."""
    conn = mavutil.mavlink_connection(url, source_system=254)
    conn.wait_heartbeat(timeout=30)
    sysid, compid = conn.target_system, conn.target_component
    conn.mav.request_data_stream_send(sysid, compid, mavutil.mavlink.MAV_DATA_STREAM_ALL, 5, 1)

    def boot_s() -> float:
        msg = conn.recv_match(type="SYSTEM_TIME", blocking=True, timeout=5)
        return msg.time_boot_ms / 1000.0 if msg else 0.0

    while boot_s() < EKF_READY_S:
        pass
    m = mavutil.mavlink
    rel = m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    items = [(m.MAV_CMD_NAV_WAYPOINT, home.lat, home.lon, 0.0, m.MAV_FRAME_GLOBAL_INT)]
    items.append((m.MAV_CMD_NAV_TAKEOFF, 0.0, 0.0, ALT_M, rel))
    items += [(m.MAV_CMD_NAV_WAYPOINT, lat, lon, ALT_M, rel) for lat, lon in waypoints]
    items.append((m.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0.0, 0.0, 0.0, rel))
    conn.mav.mission_count_send(sysid, compid, len(items), m.MAV_MISSION_TYPE_MISSION)
    while True:
        msg = conn.recv_match(type=["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"],
                              blocking=True, timeout=10)  # fmt: skip
        if msg is None or msg.get_type() == "MISSION_ACK":
            break
        cmd, lat, lon, alt, frame = items[msg.seq]
        conn.mav.mission_item_int_send(
            sysid, compid, msg.seq, frame, cmd, 0, 1, 0, 0, 0, 0,
            int(lat * 1e7), int(lon * 1e7), alt, m.MAV_MISSION_TYPE_MISSION,
        )  # fmt: skip
    conn.set_mode("GUIDED")
    t0 = boot_s()
    conn.mav.command_long_send(
        sysid, compid, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0
    )
    conn.motors_armed_wait()
    conn.mav.command_long_send(sysid, compid, m.MAV_CMD_MISSION_START, 0, 0, 0, 0, 0, 0, 0, 0)
    conn.motors_disarmed_wait()
    t1 = boot_s()
    conn.close()
    return {"time_s": t1 - t0}


def run_case(
    name: str, sitl: tuple[Path, Path | None], folder: Path, twice: bool
) -> list[dict[str, Any]]:
    make_spec, count, options = CASES[name]
    params = CAMERA if "area" in name else None
    folder.mkdir(parents=True, exist_ok=True)
    with ground_stack(folder) as ground, contextlib.ExitStack() as stack:
        drones = [f"SITL_{i + 1}" for i in range(count)]
        vehicles = [fly_drone(stack, ground, sitl, folder, d, params=params) for d in drones]
        h = ground.drone(drones[0])["home"]
        home = LLA(h["lat"], h["lon"], h["alt_m"])
        spec = make_spec(home, **options)
        ours = fly_ours(ground, spec, drones)
        again = None
        if twice:  # a fresh pack each, then the same mission estimated with the measured draw
            # ArduPilot resets a battery only when disarmed: each vehicle is down first (home by
            # the default end; an RTL for any that is not).
            for d in drones:
                if ground.drone(d)["state"] != "disarmed":
                    ground.api("POST", f"/api/v1/drones/{d}/commands/rtl")
            deadline = time.monotonic() + 300
            while any(ground.drone(d)["state"] != "disarmed" for d in drones):
                if time.monotonic() > deadline:
                    raise TimeoutError("the vehicles did not land and disarm after RTL")
                time.sleep(1)
            for _attempt in range(3):
                for vehicle in vehicles:
                    vehicle.swap_battery()
                deadline = time.monotonic() + 20
                while any(ground.drone(d)["battery"]["remaining_pct"] < 99 for d in drones):
                    if time.monotonic() > deadline:
                        break
                    time.sleep(0.5)
                else:
                    break
            else:
                raise TimeoutError("the fresh batteries never showed")
            again = fly_ours(ground, spec, drones)
    with contextlib.ExitStack() as stack:
        from support.sitl import sitl_vehicle

        vehicle = stack.enter_context(sitl_vehicle(sitl, folder / "reference", params))
        reference = fly_auto(vehicle.url, home, waypoints_of(ours["work"]))
    rows = [{"case": name, **ours, "reference_s": reference["time_s"]}]
    if again is not None:
        rows.append({"case": "  again, draw measured", **again, "reference_s": reference["time_s"]})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument(
        "--twice",
        action="store_true",
        help="fly each case again on a fresh battery: the estimate then uses the measured draw",
    )
    args = parser.parse_args()
    source = os.environ.get("ARDUPILOT_SITL")
    if not source:
        sys.exit("set ARDUPILOT_SITL to ArduPilot Copter SITL (README)")
    path = Path(source)
    binary = path / "arducopter.gz" if path.is_dir() else path
    parm = (path if path.is_dir() else path.parent) / "copter.parm"
    with tempfile.TemporaryDirectory(prefix="dronefleet-parity-") as tmp:
        sitl = (unpack(binary, Path(tmp)), parm if parm.exists() else None)
        print(
            f"{'case':<28} {'ours s':>7} {'estimate s':>10} {'AUTO s':>7} {'ours/AUTO':>9} "
            f"{'est/ours':>8} {'batt used':>9} {'batt est':>8}  end"
        )
        for i, name in enumerate(args.cases):
            try:
                rows = run_case(name, sitl, Path(tmp) / f"case{i}", args.twice)
            except Exception as exc:  # one case failing does not stop the others
                print(f"{name:<28} failed: {type(exc).__name__}: {exc}", flush=True)
                continue
            for r in rows:
                print(
                    f"{r['case']:<28} {r['time_s']:>7.1f} {r['estimate_s']:>10.1f} "
                    f"{r['reference_s']:>7.1f} {r['time_s'] / r['reference_s']:>9.2f} "
                    f"{r['estimate_s'] / r['time_s']:>8.2f} {r['battery_used']:>8.1f}% "
                    f"{r['estimate_battery'] or 0:>7.1f}%  {r['state']}"
                    + (f" ({r['error']})" if r["error"] else ""),
                    flush=True,
                )
            time.sleep(1)


if __name__ == "__main__":
    main()
