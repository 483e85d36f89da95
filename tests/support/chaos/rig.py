"""The rig: the ground broker, three bridged drones and the ground as real processes, and the
faults made on them."""

from __future__ import annotations

import contextlib
import math
import os
import secrets
import signal
import subprocess
import sys
import threading
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

import httpx

from dronefleet.messaging.embedded import free_port
from support.brokers import MOSQUITTO
from support.chaos.link import ChaosLink
from support.chaos.parts import BrokerPart, Part
from support.chaos.schedule import (
    AREA_EAST_M,
    AREA_N_M,
    AREA_NORTH_M,
    AREA_SPACING_M,
    DRONES,
    HOME,
    HOME_STEP_E_M,
    Fault,
    Schedule,
)
from support.processes import dronefleet


def bridge(drone_id: str, ground_port: int) -> str:
    """The bridge section ``dronefleet bridge-config`` writes for the drone."""
    args = ["bridge-config", "--drone-id", drone_id, "--ground", f"127.0.0.1:{ground_port}"]
    return subprocess.run(dronefleet(*args), check=True, capture_output=True, text=True).stdout


def home_of(i: int) -> tuple[float, float, float]:
    from dronefleet.geo.ned import ned_to_lla
    from dronefleet.geo.types import LLA, NED

    p = ned_to_lla(NED(0.0, i * HOME_STEP_E_M), LLA(*HOME))
    return (round(p.lat, 7), round(p.lon, 7), HOME[2])


def area_spec(drones: list[str]) -> dict[str, Any]:
    """The area: 60 m east x 40 m north, 20 m north of the homes, at 10 m spacing; 3 drones."""
    from dronefleet.geo.ned import ned_to_lla
    from dronefleet.geo.types import LLA, NED

    corners = [(0, 0), (AREA_N_M, 0), (AREA_N_M, AREA_EAST_M), (0, AREA_EAST_M)]
    polygon = [
        [round(p.lat, 7), round(p.lon, 7)]
        for p in (ned_to_lla(NED(AREA_NORTH_M + n, e), LLA(*HOME)) for n, e in corners)
    ]
    area = {"polygon": polygon, "spacing_m": AREA_SPACING_M, "altitude_m": 10, "angle_deg": 90}
    options = {"collaboration": False}
    return {"name": "chaos", "drones": drones, "area": area, "options": options}


class Rig:
    """The topology of one run; the faults are applied by :meth:`apply` (a thread each)."""

    def __init__(self, tmp: Path, schedule: Schedule) -> None:
        self.tmp, self.schedule = tmp, schedule
        tag = secrets.token_hex(2).upper()
        self.drones = [f"CH{tag}_{i + 1}" for i in range(DRONES)]
        self.token = secrets.token_urlsafe(16)
        self.http = free_port()
        self.api = httpx.Client(
            base_url=f"http://127.0.0.1:{self.http}",
            headers={"Authorization": f"Bearer {self.token}"},
            timeout=10,
        )
        self.events: list[tuple[float, str]] = []  # (wall time, what happened)
        self.t0 = time.time()
        self.mounted: Path | None = None
        self.filler: Path | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.parts: dict[str, Part] = {}
        self.brokers: dict[str, BrokerPart] = {}
        self.links: dict[str, ChaosLink] = {}
        self.busy: list[subprocess.Popen[bytes]] = []
        self._threads: list[threading.Thread] = []
        # Every span of wall time a fault touched a drone (for ``home``): drone -> [(from, to)].
        self.touched: dict[str, list[tuple[float, float]]] = defaultdict(list)
        # Spans a drone's process was stopped (SIGSTOP): its simulated vehicle stood still.
        self.frozen: dict[str, list[tuple[float, float]]] = defaultdict(list)

    # -- set-up and tear-down
    def note(self, what: str) -> None:
        with self._lock:
            self.events.append((time.time(), what))

    def state_dir(self) -> Path:
        folder = self.tmp / "ground"
        folder.mkdir(exist_ok=True)
        if os.geteuid() == 0 and self.mounted is None:
            # 80 MB: above the 64 MB under which GET /api/v1/health calls the disk nearly full,
            # so the ground is healthy until the fault fills it.
            done = subprocess.run(
                ["mount", "-t", "tmpfs", "-o", "size=80m,mode=0755", "tmpfs", str(folder)],
                capture_output=True,
                text=True,
            )
            if done.returncode == 0:
                self.mounted = folder
            else:
                self.note(f"no tmpfs for the ground's state: {done.stderr.strip()}")
        return folder

    def start(self) -> None:
        if not Path(MOSQUITTO).exists():
            raise RuntimeError(
                "mosquitto is not installed: run `make system-deps` (apt-get install mosquitto)"
            )
        for _ in range(self.schedule.busy):
            self.busy.append(subprocess.Popen([sys.executable, "-c", "while True: pass"]))
        self.ground_broker = BrokerPart("ground_broker", self.tmp / "ground-broker")
        self.ground_broker.start()
        for i, drone_id in enumerate(self.drones):
            link = ChaosLink(self.ground_broker.port, seed=self.schedule.seed * 10 + i).start()
            self.links[drone_id] = link
            conf = bridge(drone_id, link.port)
            broker = BrokerPart(f"{drone_id}.broker", self.tmp / f"{drone_id}-broker", conf)
            broker.start()
            self.brokers[drone_id] = broker
            folder = self.tmp / drone_id
            folder.mkdir(exist_ok=True)
            lat, lon, alt = home_of(i)
            cmd = dronefleet(
                "drone", "--id", drone_id, "--broker", broker.broker.url.full(), "--fc", "sim",
                "--home", f"{lat},{lon},{alt}", "--speedup", f"{self.schedule.speedup:g}",
                "--state-dir", str(folder / "state"), "--log-dir", str(folder / "logs"),
            )  # fmt: skip
            self.parts[drone_id] = Part(drone_id, cmd, self.tmp / f"{drone_id}.out")
            self.parts[drone_id].start()
        state = self.state_dir()
        cmd = dronefleet(
            "ground", "--broker", self.ground_broker.broker.url.full(),
            "--store", f"sqlite:///{state}/telemetry.db", "--state", str(state / "ground.db"),
            "--http", f"127.0.0.1:{self.http}", f"--token={self.token}",
            "--command-timeout", "20",
        )  # fmt: skip
        self.parts["ground"] = Part("ground", cmd, self.tmp / "ground.log")
        self.parts["ground"].start()
        supervisor = threading.Thread(target=self._supervise, daemon=True)
        supervisor.start()
        self._threads.append(supervisor)
        self.wait_up()

    def wait_up(self, timeout_s: float = 240.0) -> None:
        deadline = time.monotonic() + timeout_s
        online: set[str] = set()
        while time.monotonic() < deadline:
            with contextlib.suppress(httpx.HTTPError, ValueError):
                fleet = self.api.get("/api/v1/drones").json()
                online = {d["drone_id"] for d in fleet if d.get("status") == "online"}
                if online >= set(self.drones):
                    return
            time.sleep(0.3)
        tail = self.parts["ground"].log.read_text(errors="replace")[-2000:]
        raise RuntimeError(f"drones online: {sorted(online)} of {self.drones}; ground log:\n{tail}")

    def close(self) -> None:
        self._stop.set()
        for thread in self._threads:
            thread.join(60)
        for part in self.parts.values():
            part.end()
        for broker in self.brokers.values():
            broker.end()
        if hasattr(self, "ground_broker"):
            self.ground_broker.end()
        for link in self.links.values():
            link.partition(False)
            link.stop()
        for proc in self.busy:
            proc.kill()
            proc.wait()
        self.api.close()
        if self.filler is not None:
            with contextlib.suppress(OSError):
                self.filler.unlink()
        if self.mounted is not None:
            # Keep what the ground wrote for the post-mortem, then let the tmpfs go.
            keep = self.tmp / "ground-state"
            subprocess.run(["cp", "-a", str(self.mounted), str(keep)], check=False)
            subprocess.run(["umount", "-l", str(self.mounted)], check=False)

    def _supervise(self) -> None:
        while not self._stop.wait(0.5):
            with self._lock:
                parts = [p for p in self.parts.values() if not (p.down or p.gone)]
            for part in parts:
                rc = part.proc.poll() if part.proc is not None else None
                if rc is None:
                    continue
                with self._lock:
                    if part.down or part.gone:
                        continue
                    part.exits.append(f"exited {rc}")
                    self.events.append((time.time(), f"{part.name} exited by itself ({rc})"))
                time.sleep(1.0)
                with self._lock:
                    if not (part.down or part.gone):
                        part.start()
            for broker in [self.ground_broker, *self.brokers.values()]:
                proc = broker.broker.proc
                if broker.down or proc is None or proc.poll() is None:
                    continue
                broker.exits.append(f"exited {proc.returncode}")
                self.note(f"{broker.name} exited by itself ({proc.returncode})")
                with contextlib.suppress(RuntimeError, TimeoutError):
                    broker.start()

    # -- faults
    def apply(self, start: float) -> None:
        """Start a thread per fault of the schedule, timed from ``start`` (wall)."""
        for fault in self.schedule.faults:
            thread = threading.Thread(target=self._fault, args=(fault, start), daemon=True)
            thread.start()
            self._threads.append(thread)

    def faults_done(self) -> bool:
        return all(not t.is_alive() for t in self._threads[1:])

    def _fault(self, fault: Fault, start: float) -> None:
        if self._stop.wait(max(0.0, start + fault.at_s - time.time())):
            return
        drone = self.drones[fault.drone] if fault.drone is not None else None
        began = time.time()
        self.note(f"begin {fault.label(self.drones)}")
        try:
            undo = self._begin(fault, drone)
        except Exception as exc:  # a fault that cannot be made is noted, not fatal
            self.note(f"{fault.kind} could not be made: {exc!r}")
            return
        if undo is None:  # for good
            if drone is not None:
                self.touched[drone].append((began, math.inf))
            return
        self._stop.wait(fault.duration_s)
        try:
            undo()
        except Exception as exc:
            self.note(f"{fault.kind} could not be undone: {exc!r}")
        self.note(f"end {fault.label(self.drones)}")
        if drone is not None:
            self.touched[drone].append((began, time.time()))
            if fault.kind == "drone.stop":
                self.frozen[drone].append((began, time.time()))

    def _begin(self, fault: Fault, drone: str | None) -> Any:
        kind = fault.kind
        if kind in ("ground.kill", "drone.kill"):
            part = self.parts["ground" if drone is None else drone]
            with self._lock:
                if part.gone:
                    return lambda: None
                part.kill()
                if fault.for_good:
                    part.gone = True
                    return None

            def restart() -> None:
                with self._lock:
                    if not part.gone and part.down:
                        part.start()

            return restart
        if kind in ("ground.stop", "drone.stop"):
            part = self.parts["ground" if drone is None else drone]
            return self._stopped(part)
        if kind.endswith("broker.kill"):
            broker = self.ground_broker if drone is None else self.brokers[drone]
            broker.kill()
            return broker.start
        if kind.endswith("broker.stop"):
            broker = self.ground_broker if drone is None else self.brokers[drone]
            return self._stopped(broker)
        if kind.startswith("link."):
            assert drone is not None
            link = self.links[drone]
            if kind == "link.partition":
                link.partition(True)
                return lambda: link.partition(False)
            if kind == "link.latency":
                link.set(latency_s=fault.level)
            else:
                link.set(latency_s=0.1, loss=fault.level)
            return lambda: link.set()
        if kind == "disk.full":
            return self._fill_disk()
        raise ValueError(f"unknown fault {kind}")

    def _stopped(self, part: Part | BrokerPart) -> Any:
        part.signal(signal.SIGSTOP)
        part.stopped = True

        def cont() -> None:
            part.stopped = False
            part.signal(signal.SIGCONT)

        return cont

    def _fill_disk(self) -> Any:
        if self.mounted is None:
            raise RuntimeError("the ground's state is on no tmpfs of ours (not root?)")
        self.filler = self.mounted / "filler"
        chunk = b"\0" * (1 << 20)
        with open(self.filler, "wb", buffering=0) as out:  # unbuffered: nothing left to close
            for size in (len(chunk), 4096, 1):
                with contextlib.suppress(OSError):
                    while True:
                        out.write(chunk[:size])
        free_bytes = os.statvfs(self.mounted).f_bavail * os.statvfs(self.mounted).f_frsize
        self.note(f"disk full: {free_bytes} bytes left under the ground's state")

        def free() -> None:
            if self.filler is not None:
                self.filler.unlink(missing_ok=True)
                self.filler = None

        return free


ENDED = ("completed", "failed", "stopped")


def fetch(rig: Rig, path: str, timeout_s: float, **params: Any) -> Any:
    """A GET answered 200 within ``timeout_s`` (the ground may be down or stopped meanwhile)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        with contextlib.suppress(httpx.HTTPError, ValueError):
            answer = rig.api.get(path, params=params)
            if answer.status_code == 200:
                return answer.json()
        time.sleep(0.5)
    return None
