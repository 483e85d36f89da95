"""PX4 SITL with the SIH quadrotor (no Gazebo) for the PX4 tests (tests/integration/px4), found
through ``PX4_SITL`` as ArduPilot SITL is through ``ARDUPILOT_SITL``.

``PX4_SITL`` names the build's folder (``bin/px4`` and ``etc/`` in it), or the folder or tarball
``px4-sitl-sih-*.tar.gz`` it was packed into (../shared/px4, unpacked once per session). PX4 runs
from a fresh working folder per vehicle (it writes parameters, dataman and logs there). Instance
N (../shared/px4/README.md): system id N+1; the companion computer's (on-board) link sends to UDP
14540+N, the ground station link listens on 18570+N; "Ready for takeoff!" about 10 s after start.
"""

from __future__ import annotations

import contextlib
import os
import random
import socket
import subprocess
import tarfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from support.processes import dronefleet, process
from support.sitl import Ground

#: PX4_SIM_SPEED_FACTOR: vehicle seconds per wall second (lockstep; at 6, on 2 loaded cores,
#: PX4 timed our mission upload out: "Operation timeout").
SPEED = 4
HOME = (47.397742, 8.545594, 488.0)


def px4_build(value: str, unpack_to: Path) -> Path:
    """The folder holding ``bin/px4`` for ``PX4_SITL=value`` (a tarball or a folder holding
    one is unpacked into ``unpack_to``)."""
    path = Path(value)
    if (path / "bin" / "px4").exists():
        return path
    packs = sorted(path.glob("px4-sitl-sih-*.tar.gz")) if path.is_dir() else [path]
    if not packs or not packs[-1].is_file():
        raise FileNotFoundError(f"PX4_SITL={value}: no bin/px4 and no px4-sitl-sih-*.tar.gz")
    with tarfile.open(packs[-1]) as tar:
        tar.extractall(unpack_to, filter="tar")
    (build,) = [p.parent.parent for p in unpack_to.glob("*/bin/px4")]
    return build


def _udp_free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        try:
            sock.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def _free_instance() -> int:
    start = random.Random().randrange(1, 9)
    for instance in range(start, start + 9):
        ports = (14540 + instance, 14580 + instance, 18570 + instance, 14280 + instance)
        if all(_udp_free(p) for p in ports):
            return instance
    raise RuntimeError("no free PX4 SITL instance (UDP 14540+N, 14580+N, 18570+N in use)")


@dataclass
class Px4Vehicle:
    instance: int
    folder: Path
    proc: subprocess.Popen[bytes]
    drone: subprocess.Popen[bytes] | None = None  # ``dronefleet drone`` on it (fly_px4)

    @property
    def url(self) -> str:
        """The companion computer's link (PX4's on-board MAVLink instance sends here)."""
        return f"udpin:127.0.0.1:{14540 + self.instance}"

    @property
    def gcs_url(self) -> str:
        """Another ground station's link (PX4's GCS MAVLink instance listens here)."""
        return f"udpout:127.0.0.1:{18570 + self.instance}"

    @property
    def system_id(self) -> int:
        return self.instance + 1

    def log(self) -> str:
        return (self.folder / "px4.log").read_text(errors="replace")

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


@contextlib.contextmanager
def px4_vehicle(build: Path, folder: Path, home=HOME) -> Iterator[Px4Vehicle]:
    """One PX4 SIH quadrotor on a free instance, ready for take-off."""
    folder.mkdir(parents=True, exist_ok=True)
    instance = _free_instance()
    env = {
        **os.environ,
        "PX4_SIM_MODEL": "sihsim_quadx",
        "PX4_SIMULATOR": "sihsim",
        "PX4_SIM_SPEED_FACTOR": str(SPEED),
        "PX4_HOME_LAT": str(home[0]),
        "PX4_HOME_LON": str(home[1]),
        "PX4_HOME_ALT": str(home[2]),
    }
    cmd = [str(build / "bin" / "px4"), "-d", "-i", str(instance), str(build / "etc")]
    with open(folder / "px4.log", "ab") as out:
        proc = subprocess.Popen(
            cmd, cwd=folder, env=env, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL
        )
    vehicle = Px4Vehicle(instance, folder, proc)
    try:
        deadline = time.monotonic() + 60
        while "Ready for takeoff" not in vehicle.log():
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"PX4 SITL not ready; its log ends:\n{vehicle.log()[-1500:]}")
            time.sleep(0.2)
        yield vehicle
    finally:
        vehicle.stop()


def fly_px4(
    stack: contextlib.ExitStack, ground: Ground, build: Path, folder: Path, drone_id: str, *extra
) -> Px4Vehicle:
    """A PX4 vehicle and ``dronefleet drone`` on its on-board link, online with a home."""
    vehicle = stack.enter_context(px4_vehicle(build, folder / drone_id))
    cmd = dronefleet(
        "-v", "drone", "--id", drone_id, "--broker", ground.broker, "--fc", "mavlink",
        "--fc-url", vehicle.url, "--heartbeat-s", "1", *extra,
    )  # fmt: skip
    vehicle.drone = stack.enter_context(process(cmd, folder / f"{drone_id}.log"))
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        drone = ground.drone(drone_id)
        if drone.get("status") == "online" and drone.get("home"):
            return vehicle
        time.sleep(0.5)
    raise TimeoutError(f"{drone_id} on PX4 not online within 60 s")


class OtherStation:
    """A second ground station on PX4's GCS link (pymavlink), as QGroundControl would be."""

    def __init__(self, vehicle: Px4Vehicle) -> None:
        from pymavlink import mavutil

        self.m = mavutil.mavlink
        self.conn = mavutil.mavlink_connection(vehicle.gcs_url, source_system=250)
        self.target = vehicle.system_id

    def set_mode(self, main: int, sub: int = 0, timeout_s: float = 10.0) -> None:
        """DO_SET_MODE (custom mode main/sub) until PX4 accepts it."""
        m = self.m
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            self.conn.mav.heartbeat_send(m.MAV_TYPE_GCS, m.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            self.conn.mav.command_long_send(
                self.target, 1, m.MAV_CMD_DO_SET_MODE, 0,
                m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, main, sub, 0, 0, 0, 0,
            )  # fmt: skip
            ack = self.conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=1)
            if ack is not None and ack.command == m.MAV_CMD_DO_SET_MODE:
                if ack.result == m.MAV_RESULT_ACCEPTED:
                    return
                raise RuntimeError(f"DO_SET_MODE {main}/{sub} refused ({ack.result})")
        raise TimeoutError("no answer to DO_SET_MODE")

    def close(self) -> None:
        self.conn.close()
