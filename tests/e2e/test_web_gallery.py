"""The Photos page (issue 14): a short survey flown with takepic on the demo, its pictures as
thumbnails with their step and position, each opened full size, and all of them downloaded as
one zip of geotagged JPEGs (read back with Pillow's EXIF reader)."""

from __future__ import annotations

import io
import json
import math
import re
import time
import zipfile

import pytest
from PIL import Image
from PIL.ExifTags import GPS, IFD

from .conftest import ARTIFACTS, M_PER_DEG, get, post_for, start_demo

pytestmark = pytest.mark.e2e


def gps_of(jpeg: bytes) -> tuple[float, float]:
    with Image.open(io.BytesIO(jpeg)) as image:
        gps = image.getexif().get_ifd(IFD.GPSInfo)

    def degrees(dms, ref) -> float:
        value = float(dms[0]) + float(dms[1]) / 60 + float(dms[2]) / 3600
        return -value if ref in ("S", "W") else value

    return (
        degrees(gps[GPS.GPSLatitude], gps[GPS.GPSLatitudeRef]),
        degrees(gps[GPS.GPSLongitude], gps[GPS.GPSLongitudeRef]),
    )


def test_a_surveys_pictures_show_as_thumbnails_and_download_as_one_zip(open_page, tmp_path):
    server = start_demo(tmp_path, "--drones", "1")
    try:
        lat, lon = 40.6302, -8.6590
        m_lon = M_PER_DEG * math.cos(math.radians(lat))
        square = [(0, 0), (0, 20), (20, 20), (20, 0)]
        polygon = [[lat + n / M_PER_DEG, lon + e / m_lon] for n, e in square]
        area = {"polygon": polygon, "spacing_m": 10, "altitude_m": 12, "action": "takepic",
                "hold_s": 0}  # fmt: skip
        spec = {"name": "photo square", "drones": ["QUAD_1"], "area": area,
                "options": {"collaboration": False, "early_replacement": False}}  # fmt: skip
        for _ in range(30):  # the drone may not be heard yet
            status, answer = post_for(server, "/missions?start=true", spec)
            if status == 201:
                break
            time.sleep(1.0)
        assert status == 201, answer
        mission = json.loads(answer)["mission_id"]
        for _ in range(180):
            record = get(server, f"/missions/{mission}")
            if record["state"] in ("completed", "failed", "stopped"):
                break
            time.sleep(1.0)
        assert record["state"] == "completed", record["error"]
        shots = sum(1 for s in record["work"] if s["command"] == "takepic")
        assert shots >= 4

        page, console = open_page("photos", server=server)
        page.wait_for_selector(f"#gallery-mission option[value='{mission}']", state="attached")
        page.select_option("#gallery-mission", mission)
        page.wait_for_selector(f"#gallery-summary[data-stored='{shots}']", timeout=30_000)
        cards = page.locator("#gallery-grid li.photo")
        page.wait_for_function(
            "() => document.querySelectorAll('#gallery-grid li[data-thumb=\"1\"]').length"
            f" === {shots}",
            timeout=20_000,
        )
        assert cards.count() == shots
        listed = get(server, f"/missions/{mission}/photos")
        for card, p in zip(cards.all(), listed, strict=True):
            text = card.inner_text()
            assert f"#{p['n']} QUAD_1" in text and f"step {p['step']}" in text, text
            assert f"{p['lat']:.6f}, {p['lon']:.6f}" in text
            width = card.locator("img.thumb").evaluate("(img) => img.naturalWidth")
            assert width == 64  # the simulated camera's picture, thumbnailed (never enlarged)
        ARTIFACTS.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(ARTIFACTS / "photos-gallery.png"))

        # A click opens the picture as the drone took it.
        cards.nth(1).locator("button.thumb-button").click()
        page.wait_for_selector("#gallery-viewer[open][data-n='2']")
        page.wait_for_function(
            "() => document.querySelector('#gallery-picture').naturalWidth === 64"
        )
        assert re.search(r"#2 QUAD_1 · step \d+", page.inner_text("#gallery-caption"))
        page.click("#gallery-viewer button[type='submit']")
        page.wait_for_selector("#gallery-viewer:not([open])", state="attached")

        with page.expect_download() as download:
            page.click("#gallery-zip")
        saved = tmp_path / download.value.suggested_filename
        download.value.save_as(saved)
        assert saved.name == f"mission-{mission}-photos.zip"
        with zipfile.ZipFile(saved) as archive:
            names = archive.namelist()
            assert names == [f"{n:04d}_QUAD_1.jpg" for n in range(1, shots + 1)]
            for name, p in zip(names, listed, strict=True):
                got = gps_of(archive.read(name))
                assert got == pytest.approx((p["lat"], p["lon"]), abs=1e-6), (name, got, p)
        console.assert_clean()
    finally:
        server.stop()
