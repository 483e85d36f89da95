"""ArduPilot Copter SITL for the real-autopilot tests (issue 17), found through ``ARDUPILOT_SITL``.

``ARDUPILOT_SITL`` names the ``arducopter`` binary, its gzip (``arducopter.gz``), or a folder that
holds either (and, optionally, SITL's ``copter.parm`` defaults). ``.ci/run`` points it at the
build beside the repository; elsewhere these tests skip with that one line. The processes are
those of :mod:`support.sitl`.

Each test then flies the way a user would: a Mosquitto of its own, ``dronefleet ground``, one
``dronefleet drone --fc mavlink`` per vehicle, and missions only through the REST API.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from support.sitl import Ground, Vehicle, fly_drone, ground_stack, unpack

pytestmark = [pytest.mark.integration, pytest.mark.sitl]


def _sitl_source() -> tuple[Path, Path | None]:
    value = os.environ.get("ARDUPILOT_SITL")
    if not value:
        pytest.skip(
            "ARDUPILOT_SITL is not set: build ArduPilot Copter SITL (README, make test-sitl)"
        )
    path = Path(value)
    folder = path if path.is_dir() else path.parent
    binary = path
    if path.is_dir():
        found = [folder / n for n in ("arducopter", "arducopter.gz") if (folder / n).exists()]
        if not found:
            pytest.fail(f"ARDUPILOT_SITL={value}: no arducopter or arducopter.gz in it")
        binary = found[0]
    if not binary.exists():
        pytest.fail(f"ARDUPILOT_SITL={value} does not exist")
    parm = folder / "copter.parm"
    return binary, parm if parm.exists() else None


@pytest.fixture(scope="session")
def sitl_binary(tmp_path_factory) -> tuple[Path, Path | None]:
    """The SITL binary (unpacked once per session into a temporary folder) and its defaults."""
    source, parm = _sitl_source()
    return unpack(source, tmp_path_factory.mktemp("ardupilot")), parm


@pytest.fixture
def ground(tmp_path) -> Iterator[Ground]:
    """A Mosquitto and ``dronefleet ground`` of this test's own."""
    with ground_stack(tmp_path) as stack:
        yield stack


@pytest.fixture
def fly(ground, sitl_binary, tmp_path):
    """``fly(drone_id, *drone_args, params={...}, home=(lat, lon, alt))``: a SITL vehicle (with
    those parameters, there) and ``dronefleet drone`` on it, online and ready to arm."""
    with contextlib.ExitStack() as stack:

        def start(drone_id: str, *extra: str, **vehicle: Any) -> Vehicle:
            return fly_drone(stack, ground, sitl_binary, tmp_path, drone_id, *extra, **vehicle)

        yield start
