"""What the drones photographed reaches the ground (issue 14).

A drone surveys a field taking a picture at every waypoint; the ground fetches each picture from
it over the broker (the Gear Manager's ``photo`` queries) and keeps it in its state folder with a
thumbnail. ``GET /missions/{id}/photos`` lists them with where and when; each picture is served
byte for byte as the drone's camera wrote it, its GPS EXIF read back with Pillow; ``photos.zip``
holds them all, geotagged, for OpenDroneMap. A picture larger than a broker message comes in
chunks.
"""

from __future__ import annotations

import asyncio
import io
import zipfile

import httpx
import pytest
from PIL import Image
from PIL.ExifTags import GPS, IFD

from dronefleet.clock import WallClock
from dronefleet.drone.config import DroneConfig
from dronefleet.drone.gear import GearManager
from dronefleet.experiments.scenarios import rectangle
from dronefleet.geo.types import LLA
from dronefleet.ground.manager.auth import Role
from dronefleet.ground.photos.collector import PhotoCollector, PictureRefused
from dronefleet.ground.photos.images import NotAPicture
from dronefleet.ground.photos.store import PhotoEntry, PhotoStore
from dronefleet.messaging.client import BrokerClient
from dronefleet.messaging.gear import PHOTO_CHUNK_BYTES, GearQuery, GearRequest
from dronefleet.messaging.rpc import Requester
from dronefleet.messaging.topics import Channel, Direction, any_drone, topic
from dronefleet.simfleet import SimFleet
from support.ground_api import flown, local_ground

pytestmark = pytest.mark.integration
HOME = LLA(40.63, -8.659, 10.0)


def gps_of(jpeg: bytes) -> tuple[float, float, float]:
    """Latitude, longitude and altitude from a JPEG's GPS EXIF, read by Pillow."""
    with Image.open(io.BytesIO(jpeg)) as image:
        gps = image.getexif().get_ifd(IFD.GPSInfo)

    def degrees(dms, ref) -> float:
        value = float(dms[0]) + float(dms[1]) / 60 + float(dms[2]) / 3600
        return -value if ref in ("S", "W") else value

    lat = degrees(gps[GPS.GPSLatitude], gps[GPS.GPSLatitudeRef])
    lon = degrees(gps[GPS.GPSLongitude], gps[GPS.GPSLongitudeRef])
    return lat, lon, float(gps[GPS.GPSAltitude])


async def until(predicate, timeout_s: float, poll_s: float = 0.1):
    for _ in range(int(timeout_s / poll_s)):
        found = await predicate()
        if found:
            return found
        await asyncio.sleep(poll_s)
    raise AssertionError(f"not within {timeout_s} s")


async def test_a_surveys_pictures_are_kept_on_the_ground_and_served_geotagged(
    embedded_broker, tmp_path
):
    ground = local_ground(embedded_broker, tmp_path, "photo-planner")
    async with ground, SimFleet(speedup=20) as fleet:
        config = DroneConfig(drone_id="CAM", log_dir=tmp_path / "drone-logs")
        await fleet.add_drone(config, embedded_broker, home=HOME)
        headers = {"Authorization": f"Bearer {ground.operator_token}"}
        # 30 s: the first plan starts the planning worker process, slow on a loaded machine.
        async with httpx.AsyncClient(base_url=ground.http_url, headers=headers, timeout=30) as api:
            await until(lambda: _ok(api.get("/api/v1/drones/CAM")), 10)
            area = {"polygon": rectangle(10, 0, 20, 20), "spacing_m": 10, "altitude_m": 15,
                    "action": "takepic", "hold_s": 0}  # fmt: skip
            spec = {"drones": ["CAM"], "area": area, "options": {"collaboration": False}}
            detail = await flown(api, spec)
            assert detail["state"] == "completed", detail["error"]
            mission_id = detail["mission_id"]
            shots = sum(1 for step in detail["work"] if step["command"] == "takepic")

            async def all_kept():
                got = (await api.get(f"/api/v1/missions/{mission_id}/photos")).json()
                return got if len(got) == shots and all(p["stored"] for p in got) else None

            photos = await until(all_kept, 30)
            pictures = {
                n: await api.get(f"/api/v1/missions/{mission_id}/photos/{n}")
                for n in range(1, shots + 1)
            }
            thumb = await api.get(f"/api/v1/missions/{mission_id}/photos/1/thumb")
            archive = await api.get(f"/api/v1/missions/{mission_id}/photos.zip")
            missing = await api.get(f"/api/v1/missions/{mission_id}/photos/{shots + 1}")
            unknown = await api.get("/api/v1/missions/nope/photos")
            viewer = await ground.app.state.ctx.tokens.issue("v", Role.VIEWER)
            as_viewer = await api.get(
                f"/api/v1/missions/{mission_id}/photos/1",
                headers={"Authorization": f"Bearer {viewer}"},
            )
            stranger = await api.get(
                f"/api/v1/missions/{mission_id}/photos/1", headers={"Authorization": ""}
            )

    reports = [r for leg in detail["legs"] for r in leg["reports"] if r["command"] == "takepic"]
    assert shots >= 4 and len(photos) == shots == len(reports)
    assert [p["n"] for p in photos] == list(range(1, shots + 1))
    assert sorted(p["step"] for p in photos) == sorted(r["index"] for r in reports)
    on_drone = tmp_path / "drone-logs" / "pictures"
    for p in photos:
        jpeg = pictures[p["n"]]
        assert jpeg.status_code == 200 and jpeg.headers["content-type"] == "image/jpeg"
        # Byte for byte what the drone's camera wrote, EXIF and all.
        assert jpeg.content == (on_drone / p["file"]).read_bytes()
        assert p["size_bytes"] == len(jpeg.content) and p["drone_id"] == "CAM"
        lat, lon, alt = gps_of(jpeg.content)
        assert abs(lat - p["lat"]) < 1e-6 and abs(lon - p["lon"]) < 1e-6, (lat, lon, p)
        assert abs(alt - p["alt_m"]) < 0.01 and p["relative_alt_m"] > 14
        # Every picture where its drone took it, and each elsewhere.
    assert len({(round(p["lat"], 6), round(p["lon"], 6)) for p in photos}) == shots
    assert thumb.status_code == 200 and thumb.headers["content-type"] == "image/jpeg"
    with Image.open(io.BytesIO(thumb.content)) as small:
        assert small.format == "JPEG" and max(small.size) <= 256
    assert archive.status_code == 200 and archive.headers["content-type"] == "application/zip"
    assert f"mission-{mission_id}-photos.zip" in archive.headers["content-disposition"]
    with zipfile.ZipFile(io.BytesIO(archive.content)) as z:
        names = z.namelist()
        assert names == [f"{n:04d}_CAM.jpg" for n in range(1, shots + 1)]
        for p, name in zip(photos, names, strict=True):
            lat, lon, _ = gps_of(z.read(name))
            assert abs(lat - p["lat"]) < 1e-6 and abs(lon - p["lon"]) < 1e-6
    assert missing.status_code == 404 and unknown.status_code == 404
    assert as_viewer.status_code == 200 and stranger.status_code == 401
    # Kept as files in the ground's state folder, beside its database.
    kept = tmp_path / "photos" / mission_id
    assert sorted(f.name for f in kept.glob("*.jpg")) == names
    assert len(list((kept / "thumbs").glob("*.jpg"))) == shots


async def _ok(response) -> bool:
    return (await response).status_code == 200


class BigCamera:
    """A camera whose pictures are larger than a broker message: a 1600x1200 noisy JPEG."""

    name = "camera"

    def __init__(self, folder) -> None:
        self.folder = folder
        self.count = 0

    def capture(self) -> dict:
        import os

        self.count += 1
        image = Image.frombytes("RGB", (1600, 1200), os.urandom(1600 * 1200 * 3))
        exif = Image.Exif()
        exif.get_ifd(IFD.GPSInfo).update(
            {GPS.GPSLatitudeRef: "N", GPS.GPSLatitude: (40.0, 37.0, 48.0),
             GPS.GPSLongitudeRef: "W", GPS.GPSLongitude: (8.0, 39.0, 36.0), GPS.GPSAltitude: 30.0}
        )  # fmt: skip
        path = self.folder / f"big_{self.count}.jpg"
        image.save(path, "JPEG", quality=95, exif=exif)
        return {"index": self.count, "lat": 40.63, "lon": -8.66, "alt_m": 30.0, "file": str(path)}


async def test_a_picture_larger_than_a_broker_message_comes_in_chunks(embedded_broker, tmp_path):
    gear_client = BrokerClient(embedded_broker, "big-gear")
    gear = GearManager("BIG", gear_client, WallClock(), gear_dir=None, camera=BigCamera(tmp_path))
    ground = BrokerClient(embedded_broker, "big-ground")
    await gear_client.start()
    await gear.start()
    await ground.start()
    try:
        ask = Requester(ground)
        capture = await ask.request(
            topic("BIG", Channel.GEAR, Direction.IN), any_drone(Channel.GEAR),
            GearRequest(query=GearQuery.CAPTURE), timeout_s=10,
        )  # fmt: skip
        file = capture["capture"]["file"].rsplit("/", 1)[-1]
        written = (tmp_path / file).read_bytes()
        assert len(written) > 3 * PHOTO_CHUNK_BYTES  # four chunks at least
        collector = PhotoCollector(embedded_broker, planner=None, store=PhotoStore(tmp_path / "g"))
        collector.requester = ask
        got = await collector.fetch("BIG", file)
        assert got == written
        assert gps_of(got) == pytest.approx((40.63, -8.66, 30.0))
        # Only the pictures this camera took are served; a name with a folder is not even asked.
        with pytest.raises(PictureRefused, match=r"took no picture 'other\.jpg'"):
            await collector.fetch("BIG", "other.jpg")
        with pytest.raises(ValueError, match="pattern"):
            GearRequest(query=GearQuery.PHOTO, photo="../../etc/passwd")
        # The ground keeps it with a thumbnail; junk that is not a picture is refused.
        store = PhotoStore(tmp_path / "g")
        entry = PhotoEntry(
            n=0,
            drone_id="BIG",
            leg_id="M1.1",
            drone_step=3,
            step=1,
            lat=40.63,
            lon=-8.66,
            file=file,
        )
        [listed] = await store.register("M1", [entry, entry])
        kept = await store.keep("M1", listed.n, got)
        assert kept.stored and kept.size_bytes == len(written)
        with Image.open(store.thumb_path("M1", kept)) as small:
            assert small.size == (256, 192)
        with pytest.raises(NotAPicture):
            await store.keep("M1", 1, b"\xff\xd8 not really a jpeg")
        assert store.picture_path("M1", kept).read_bytes() == written  # the good one stays
    finally:
        await ground.stop()
        await gear.stop()
        await gear_client.stop()


async def test_a_fly_through_surveys_triggered_pictures_all_reach_the_gallery(
    embedded_broker, tmp_path
):
    """Photographed on the move (the distance trigger, as DO_SET_CAM_TRIGG_DIST): no takepic
    steps, yet every picture the trigger took is listed, fetched and geotagged."""
    ground = local_ground(embedded_broker, tmp_path, "trigger-photo-planner")
    async with ground, SimFleet(speedup=20) as fleet:
        config = DroneConfig(drone_id="FLY", log_dir=tmp_path / "drone-logs")
        await fleet.add_drone(config, embedded_broker, home=HOME)
        headers = {"Authorization": f"Bearer {ground.operator_token}"}
        async with httpx.AsyncClient(base_url=ground.http_url, headers=headers, timeout=30) as api:
            await until(lambda: _ok(api.get("/api/v1/drones/FLY")), 10)
            area = {"polygon": rectangle(10, 0, 20, 30), "spacing_m": 10, "altitude_m": 15,
                    "action": "takepic", "fly_through": True, "trigger_distance_m": 6}  # fmt: skip
            spec = {"drones": ["FLY"], "area": area, "options": {"collaboration": False}}
            detail = await flown(api, spec)
            assert detail["state"] == "completed", detail["error"]
            mission_id = detail["mission_id"]
            on_drone = sorted((tmp_path / "drone-logs" / "pictures").glob("*.jpg"))

            seen: list = []

            async def all_kept():
                got = (await api.get(f"/api/v1/missions/{mission_id}/photos")).json()
                seen[:] = [(p["file"], p["stored"], p.get("error")) for p in got]
                return got if len(got) == len(on_drone) and all(p["stored"] for p in got) else None

            try:
                photos = await until(all_kept, 30)
            except AssertionError as exc:
                raise AssertionError(f"{exc}: on the drone {[f.name for f in on_drone]}, "
                                     f"listed {seen}") from None  # fmt: skip
            last = await api.get(f"/api/v1/missions/{mission_id}/photos/{len(photos)}")

    assert not any(s["command"] == "takepic" for s in detail["work"])
    assert len(on_drone) >= 6  # several per swath, taken on the move
    assert sorted(p["file"] for p in photos) == [f.name for f in on_drone]
    assert len({(round(p["lat"], 6), round(p["lon"], 6)) for p in photos}) == len(photos)
    # At the survey's 15 m, within the vertical tolerance of the wait before the trigger is set.
    heights = [p["relative_alt_m"] for p in photos]
    assert all(13.0 < h < 16.0 for h in heights), heights
    assert (
        last.status_code == 200
        and last.content == (tmp_path / "drone-logs" / "pictures" / photos[-1]["file"]).read_bytes()
    )
