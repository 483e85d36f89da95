"""What the drones measured: sensor readings and pictures, kept per step and exported (issue 14).

A ``read_sensors`` step reports its readings (``{"readings": {"CO2": {"value": 412.0, "unit":
"ppm", ...}}}``) and a ``takepic`` its picture record (``{"capture": {"lat": ..., "file": ...}}``);
the planner keeps them with the step (``StepReport.measured``) and the mission log carries them.
Exported as GeoJSON (RFC 7946: one Point feature per reading, longitude first) for GIS tools and
the map layer, or as CSV (one row per reading) for spreadsheets. Written by hand: both formats
are a few lines of JSON and csv from the standard library; a GIS library (geojson, shapely) would
add a dependency for nothing more.
"""

from __future__ import annotations

import csv
import io
import math
from typing import Any

from dronefleet.ground.planner.models import MissionRecord

#: The columns of the CSV export, in order.
COLUMNS = (
    "drone_id", "index", "vehicle_time_s", "lat", "lon", "alt_m", "sensor", "value", "unit",
)  # fmt: skip


#: At most this many distance-triggered pictures are kept from one report.
MAX_CAPTURES = 10_000


def measured(result: dict[str, Any] | None) -> dict[str, Any] | None:
    """What of a step's result is a measurement: its readings, its picture (takepic) and the
    pictures the distance trigger took since the last report (``captures``), else None."""
    if not result:
        return None
    kept = {k: result[k] for k in ("readings", "capture") if isinstance(result.get(k), dict)}
    shots = result.get("captures")
    if isinstance(shots, list):
        shots = [c for c in shots[:MAX_CAPTURES] if isinstance(c, dict)]
        if shots:
            kept["captures"] = shots
    return kept or None


def readings(record: MissionRecord) -> list[dict[str, Any]]:
    """One row per sensor reading of the mission, in the order the drones took them."""
    rows: list[dict[str, Any]] = []
    for leg in record.legs:
        for report in leg.reports:
            found = (report.measured or {}).get("readings") or {}
            where = report.position or {}
            for sensor, reading in found.items():
                if not isinstance(reading, dict) or not _number(reading.get("value")):
                    continue  # a sensor that failed to read: nothing to map
                extra = reading.get("extra") or {}
                rows.append(
                    {
                        "drone_id": leg.drone_id,
                        "index": report.index,
                        "vehicle_time_s": reading.get("vehicle_time_s", report.vehicle_time_s),
                        "lat": extra.get("lat", where.get("lat")),
                        "lon": extra.get("lon", where.get("lon")),
                        "alt_m": extra.get("alt_m", where.get("alt_m")),
                        "sensor": sensor,
                        "value": float(reading["value"]),
                        "unit": reading.get("unit", ""),
                    }
                )
    return [row for row in rows if _number(row["lat"]) and _number(row["lon"])]


def geojson(rows: list[dict[str, Any]]) -> dict[str, Any]:
    features = [
        {
            "type": "Feature",
            "geometry": {"type": "Point", "coordinates": _coordinates(row)},
            "properties": {k: v for k, v in row.items() if k not in ("lat", "lon", "alt_m")},
        }
        for row in rows
    ]
    return {"type": "FeatureCollection", "features": features}


def csv_text(rows: list[dict[str, Any]]) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


def _coordinates(row: dict[str, Any]) -> list[float]:
    alt = row["alt_m"]
    return [row["lon"], row["lat"], *([alt] if _number(alt) else [])]


def _number(value: Any) -> bool:
    """A finite number (JSON has no NaN; a map cannot place one)."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
