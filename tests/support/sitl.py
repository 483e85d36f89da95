"""ArduPilot Copter SITL and the dronefleet processes that fly it, for the real-autopilot tests
(tests/integration/sitl) and bench/ardupilot_parity.py.

SITL runs from a fresh folder per vehicle (it writes ``eeprom.bin`` and logs where it runs) on free
instance numbers (SERIAL0 on TCP 5760 + 10·N), and is retried once if it exits at start. The
binary is never copied into the repository: callers find it through ``ARDUPILOT_SITL``.
"""

from __future__ import annotations

import contextlib
import gzip
import random
import shutil
import socket
import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx

from dronefleet.messaging.embedded import free_port
from support.brokers import mosquitto
from support.processes import dronefleet, process

#: Vehicle seconds per wall second for SITL.
SITL_SPEEDUP = 10
#: ArduPilot counts FS_GCS_TIMEOUT (5 s by default) on its own clock: at 10x that is 0.5 wall s,
#: and a drone process held up that long by a loaded CI host (two xdist workers, the fuzzer and
#: the browser tests beside it) had its live copter switched to RTL by the GCS failsafe at
#: take-off. Scaled by the speed-up, the timeout means in wall time what the default means on a
#: real copter. The test of the failsafe itself (test_orphan_goes_home.py) asks for the default.
SPED_UP_PARAMS = {"FS_GCS_TIMEOUT": 5.0 * SITL_SPEEDUP}
#: SITL's EKF uses GPS after about 41 vehicle seconds; before that ArduPilot refuses to arm
#: ("Need Position Estimate"), as a real copter just powered on would.
EKF_READY_S = 45.0
HOME = (40.63, -8.66, 10.0)
TOKEN = "sitl-operator-token-0123456789abcdef"


def unpack(source: Path, folder: Path) -> Path:
    """The runnable binary: ``source`` itself, or its gzip unpacked into ``folder``."""
    if source.suffix != ".gz":
        return source
    target = folder / "arducopter"
    with gzip.open(source, "rb") as packed, open(target, "wb") as out:
        shutil.copyfileobj(packed, out)
    target.chmod(0o755)
    return target


def _instance_free(instance: int) -> bool:
    for port in range(5760 + 10 * instance, 5764 + 10 * instance):
        with socket.socket() as sock:
            try:
                sock.bind(("127.0.0.1", port))
            except OSError:
                return False
    return True


def _free_instance() -> int:
    # From a random instance on: two test processes (pytest-xdist) starting SITL at once would
    # otherwise both find the same first free one.
    start = random.Random().randrange(3, 40)
    for instance in range(start, start + 60):
        if _instance_free(instance):
            return instance
    raise RuntimeError(f"no free SITL instance number from {start} on (TCP 5760 + 10·N in use)")


@dataclass
class Vehicle:
    instance: int
    folder: Path
    proc: subprocess.Popen[bytes]
    cmd: list[str]

    @property
    def url(self) -> str:
        return f"tcp:127.0.0.1:{5760 + 10 * self.instance}"

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()

    @property
    def second_url(self) -> str:
        """SERIAL1: a second ground station's link (SERIAL0 is the drone's)."""
        return f"tcp:127.0.0.1:{5762 + 10 * self.instance}"

    def swap_battery(self, pct: float = 100.0) -> None:
        """A fresh pack, as after landing and changing it: MAV_CMD_BATTERY_RESET to ``pct``
        (a full one by default; less for a vehicle that must be relieved in flight)."""
        from pymavlink import mavutil

        conn = mavutil.mavlink_connection(self.second_url, source_system=251)
        try:
            conn.wait_heartbeat(timeout=10)
            m = mavutil.mavlink
            for _ in range(5):
                conn.mav.command_long_send(
                    conn.target_system, 1, m.MAV_CMD_BATTERY_RESET, 0, 0xFF, pct, 0, 0, 0, 0, 0
                )
                ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=2)
                if ack is not None and ack.command == m.MAV_CMD_BATTERY_RESET:
                    if ack.result != m.MAV_RESULT_ACCEPTED:
                        raise RuntimeError(f"BATTERY_RESET refused ({ack.result})")
                    return
            raise TimeoutError("no answer to BATTERY_RESET")
        finally:
            conn.close()

    def restart(self) -> None:
        """Start the same vehicle again (same folder, instance and parameters)."""
        self.kill()
        log = open(self.folder / "sitl.log", "ab")  # noqa: SIM115 - closed with the process
        self.proc = subprocess.Popen(self.cmd, cwd=self.folder, stdout=log, stderr=log)


def _start_sitl(
    binary: Path,
    parm: Path | None,
    folder: Path,
    instance: int,
    params: dict[str, float],
    home: tuple[float, float, float] = HOME,
) -> Vehicle:
    folder.mkdir(parents=True, exist_ok=True)
    cmd = [
        str(binary), "--model", "+", "--speedup", str(SITL_SPEEDUP),
        "--home", ",".join(str(x) for x in (*home, 0)), "-I", str(instance),
        "--sysid", str(instance + 1),
    ]  # fmt: skip
    defaults = [str(parm)] if parm is not None else []
    if params:
        extra = folder / "test.parm"
        extra.write_text("".join(f"{name} {value}\n" for name, value in params.items()))
        defaults.append(str(extra))
    if defaults:
        cmd += ["--defaults", ",".join(defaults)]
    log = open(folder / "sitl.log", "ab")  # noqa: SIM115 - closed with the process
    proc = subprocess.Popen(cmd, cwd=folder, stdout=log, stderr=subprocess.STDOUT)
    # Ready when it waits for its SERIAL0 client (its clock starts with that client: no probe).
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and proc.poll() is None:
        if b"Waiting for connection" in (folder / "sitl.log").read_bytes():
            break
        time.sleep(0.1)
    return Vehicle(instance, folder, proc, cmd)


@contextlib.contextmanager
def sitl_vehicle(
    sitl_binary: tuple[Path, Path | None],
    folder: Path,
    params: dict[str, float] | None = None,
    home: tuple[float, float, float] = HOME,
) -> Iterator[Vehicle]:
    """One SITL Copter on a free instance number, retried once if it exits at start;
    ``params`` are loaded as defaults after SITL's own; ``home``: lat, lon, metres above sea."""
    binary, parm = sitl_binary
    params = {**SPED_UP_PARAMS, **(params or {})}
    vehicle = None
    for attempt in range(2):
        folder_n = folder / f"try{attempt}"
        vehicle = _start_sitl(binary, parm, folder_n, _free_instance(), params, home)
        if vehicle.proc.poll() is None:
            break
    assert vehicle is not None
    if vehicle.proc.poll() is not None:
        log = (vehicle.folder / "sitl.log").read_text(errors="replace")[-1500:]
        raise RuntimeError(f"ArduPilot SITL exited at start twice; its log ends:\n{log}")
    try:
        yield vehicle
    finally:
        vehicle.kill()


@dataclass
class Ground:
    url: str
    broker: str
    folder: Path

    def api(self, method: str, path: str, **kwargs) -> httpx.Response:
        headers = {"Authorization": f"Bearer {TOKEN}"}
        return httpx.request(method, f"{self.url}{path}", headers=headers, timeout=60, **kwargs)

    def drone(self, drone_id: str) -> dict:
        response = self.api("GET", f"/api/v1/drones/{drone_id}")
        return response.json() if response.status_code == 200 else {}

    def wait_online(self, drone_id: str, timeout_s: float = 60) -> dict:
        """Until the drone is online and its autopilot has a position estimate to arm with."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            drone = self.drone(drone_id)
            ready = (drone.get("vehicle_time_s") or 0) >= EKF_READY_S
            if drone.get("status") == "online" and drone.get("home") and ready:
                return drone
            time.sleep(0.5)
        raise TimeoutError(f"{drone_id} not online within {timeout_s} s")

    def run_mission(self, spec: dict, timeout_s: float = 240) -> dict:
        """Create and start ``spec`` through the REST API; the mission once it has ended."""
        created = self.api("POST", "/api/v1/missions?start=true", json=spec)
        if created.status_code != 201:
            raise AssertionError(f"mission refused ({created.status_code}): {created.text}")
        return self.wait_ended(created.json()["mission_id"], timeout_s)

    def wait_ended(self, mission_id: str, timeout_s: float = 240) -> dict:
        deadline = time.monotonic() + timeout_s
        mission: dict = {}
        while time.monotonic() < deadline:
            mission = self.api("GET", f"/api/v1/missions/{mission_id}").json()
            if mission["state"] in ("completed", "failed", "stopped"):
                return mission
            time.sleep(1)
        raise TimeoutError(f"mission {mission_id} still {mission.get('state')} after {timeout_s}s")


@contextlib.contextmanager
def ground_stack(folder: Path) -> Iterator[Ground]:
    """A Mosquitto and ``dronefleet ground`` of our own, in ``folder``."""
    with mosquitto(folder) as broker:
        port = free_port()
        cmd = dronefleet(
            "ground", "--broker", str(broker), "--store", f"sqlite:///{folder}/telemetry.db",
            "--state", str(folder / "ground.db"), "--http", f"127.0.0.1:{port}",
            "--token", TOKEN, "--command-timeout", "30",
        )  # fmt: skip
        with process(cmd, folder / "ground.log"):
            url = f"http://127.0.0.1:{port}"
            deadline = time.monotonic() + 60
            while not _healthy(url):
                if time.monotonic() > deadline:
                    log = (folder / "ground.log").read_text(errors="replace")[-1500:]
                    raise TimeoutError(f"dronefleet ground not up at {url}; its log ends:\n{log}")
                time.sleep(0.2)
            yield Ground(url, str(broker), folder)


def _healthy(url: str) -> bool:
    with contextlib.suppress(httpx.HTTPError):
        return httpx.get(f"{url}/api/v1/health", timeout=1).status_code == 200
    return False


def fly_drone(
    stack: contextlib.ExitStack,
    ground: Ground,
    sitl: tuple[Path, Path | None],
    folder: Path,
    drone_id: str,
    *extra: str,
    params: dict[str, float] | None = None,
    home: tuple[float, float, float] = HOME,
) -> Vehicle:
    """A SITL vehicle (with ``params``, at ``home``) and ``dronefleet drone`` on it, online and
    ready to arm; both stop when ``stack`` closes."""
    vehicle = stack.enter_context(sitl_vehicle(sitl, folder / drone_id, params, home))
    cmd = dronefleet(
        "-v", "drone", "--id", drone_id, "--broker", ground.broker, "--fc", "mavlink",
        "--fc-url", vehicle.url, "--heartbeat-s", "1", *extra,
    )  # fmt: skip
    stack.enter_context(process(cmd, folder / f"{drone_id}.log"))
    ground.wait_online(drone_id)
    return vehicle
