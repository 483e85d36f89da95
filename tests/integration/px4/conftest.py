"""PX4 SITL (the SIH quadrotor) for the PX4 tests (issue 28, item 7), found through ``PX4_SITL``.

``.ci/run`` points ``PX4_SITL`` at ../shared/px4 when that build is there; elsewhere these tests
skip with one line. Each test flies as a user would: a Mosquitto and ``dronefleet ground`` of its
own, ``dronefleet drone --fc mavlink`` on PX4's on-board link, missions through the REST API.
One PX4 at a time (it is the heavy part on 2 cores).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from support.px4 import Px4Vehicle, fly_px4, px4_build
from support.sitl import Ground, ground_stack

pytestmark = [pytest.mark.integration, pytest.mark.px4]


@pytest.fixture(scope="session")
def px4(tmp_path_factory) -> Path:
    """The PX4 SITL build (unpacked once per session when ``PX4_SITL`` names its tarball)."""
    value = os.environ.get("PX4_SITL")
    if not value:
        pytest.skip("PX4_SITL is not set: point it at ../shared/px4 (README, PX4 SITL)")
    return px4_build(value, tmp_path_factory.mktemp("px4"))


@pytest.fixture
def ground(tmp_path) -> Iterator[Ground]:
    with ground_stack(tmp_path) as stack:
        yield stack


@pytest.fixture
def fly(ground, px4, tmp_path):
    """``fly(drone_id, *drone_args)``: a PX4 vehicle and ``dronefleet drone`` on it, online."""
    with contextlib.ExitStack() as stack:

        def start(drone_id: str, *extra: str) -> Px4Vehicle:
            return fly_px4(stack, ground, px4, tmp_path, drone_id, *extra)

        yield start
