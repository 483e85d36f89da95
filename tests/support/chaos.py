"""Chaos over the seed's real topology (issue 26, item 8): drawn fault schedules, flown and checked.

The topology is tests/integration/planner/test_faults_real_topology.py's, with three drones: a
ground Mosquitto; per drone a Mosquitto bridged to it with the configuration ``dronefleet
bridge-config`` writes, its bridge going through a :class:`ChaosLink` (a TCP proxy whose latency,
loss and partitions change while it runs), and ``dronefleet drone --fc sim --state-dir
--log-dir``; ``dronefleet ground`` with its state (and telemetry) on a tmpfs of its own when run
as root, so the disk can be filled. An area (60 x 40 m at 10 m spacing) is posted over REST for
the three drones and, while it is flown, the schedule's faults come and go: SIGKILL (then a
restart, or for good for a drone) and SIGSTOP (then SIGCONT) of the ground, a drone process, a
drone's broker or the ground broker; latency, loss and a partition on a drone's link; the
ground's disk full. Optionally two busy loops (``python -c "while True: pass"``) share the CPU.

A schedule is drawn from its seed alone (:func:`draw`): the same seed, the same faults at the
same times; what the software makes of them may differ from run to run.

After each run (:func:`run`) the checks, each ``ok``, a failure with what failed, or ``n/a``:

- ``reports``: every report a drone sent (its own ``reports.db``, and for a drone killed for good
  the reports its logger saw reach its broker) is in the planner's record (``legs[].seqs``);
  reports of legs that ended the drone's part (recovery legs) and arrived after the mission
  ended are counted apart (``late``).
- ``once``: no waypoint (a ``wait_for_flight`` work step) was reached by two drones, or twice,
  by what the drones themselves reported; and, the mission completed, every one was reached.
- ``ended``: the mission ``completed`` with ``ended_at`` set, whenever some drone was left to
  finish it (else n/a: it may fail or stall).
- ``home``: no drone was sent home (a recovery leg: RTL) without a cause: it was replaced
  after a fault of its own (its process, its broker, its link) or a CRITICAL alarm, or it was
  a replacement whose takeover was called off.
- ``apart``: no two drones in the air were within 5 m horizontally and 3 m vertically at once
  (the README's rule), by the positions each drone's own log recorded (5 Hz of vehicle time).
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import json
import math
import os
import random
import secrets
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx

from dronefleet.messaging.embedded import free_port
from support.brokers import MOSQUITTO, Mosquitto
from support.link_proxy import LinkProxy
from support.processes import dronefleet

# -- the schedule ------------------------------------------------------------------------------

#: Every fault the suite draws from. ``*.kill``: SIGKILL, started again after the fault's
#: duration (a drone sometimes never); ``*.stop``: SIGSTOP, then SIGCONT.
KINDS = (
    "ground.kill",
    "ground.stop",
    "drone.kill",
    "drone.stop",
    "drone_broker.kill",
    "drone_broker.stop",
    "ground_broker.kill",
    "ground_broker.stop",
    "link.latency",
    "link.loss",
    "link.partition",
    "disk.full",
)
#: Faults aimed at one drone (its process, its broker or its link).
PER_DRONE = ("drone.", "drone_broker.", "link.")
DRONES = 3
HOME = (40.63, -8.659, 10.0)
#: Metres north of the homes where the area starts, its size (east x north) and spacing.
AREA_NORTH_M, AREA_EAST_M, AREA_N_M, AREA_SPACING_M = 20.0, 60.0, 40.0, 10.0
#: The homes, 12 m apart along the east.
HOME_STEP_E_M = 12.0
#: Vehicle seconds the mission takes without faults, to place the faults within it (measured
#: with ``bench/chaos.py --baseline``: 69 s at 1x, 14 s wall at 5x).
MISSION_VEHICLE_S = 75.0
FAULTS = (1, 3)
DURATION_S = (2.0, 30.0)
FOR_GOOD_P = 0.3
SEPARATION_H_M, SEPARATION_V_M = 5.0, 3.0


@dataclass(frozen=True)
class Fault:
    kind: str
    at_s: float  # wall seconds after the mission was started
    duration_s: float
    drone: int | None = None  # index of the drone it hits (per-drone faults)
    for_good: bool = False  # a drone killed and never started again
    level: float = 0.0  # link.latency: seconds each way; link.loss: the loss probability

    def label(self, drones: list[str] | None = None) -> str:
        who = ""
        if self.drone is not None:
            who = f"[{drones[self.drone] if drones else f'd{self.drone}'}]"
        what = f"{self.kind}{who}@{self.at_s:.0f}s"
        if self.for_good:
            return what + "/forever"
        extra = ""
        if self.kind == "link.latency":
            extra = f",{self.level * 1000:.0f}ms"
        elif self.kind == "link.loss":
            extra = f",{self.level:.0%}"
        return f"{what}+{self.duration_s:.0f}s{extra}"


@dataclass(frozen=True)
class Schedule:
    seed: int
    speedup: float
    busy: int  # busy-loop processes beside the fleet
    faults: tuple[Fault, ...]

    def label(self) -> str:
        return " ".join(f.label() for f in self.faults) or "none"


def mission_wall_s(speedup: float) -> float:
    return MISSION_VEHICLE_S / speedup


def draw(
    seed: int,
    *,
    speedups: tuple[float, ...] = (1.0, 5.0),
    busy: tuple[int, ...] = (0, 2),
    kinds: tuple[str, ...] = KINDS,
    faults: tuple[int, int] = FAULTS,
) -> Schedule:
    """The schedule of ``seed``: its speed-up, busy loops and 1-3 faults (kind, start within the
    mission's expected wall time, duration 2-30 s, target drone, for good or not)."""
    rng = random.Random(seed)
    speedup = rng.choice(speedups)
    loops = rng.choice(busy)
    span = mission_wall_s(speedup)
    drawn = []
    for _ in range(rng.randint(*faults)):
        kind = rng.choice(kinds)
        at_s = round(rng.uniform(0.05, 0.7) * span, 1)
        duration_s = round(rng.uniform(*DURATION_S), 1)
        drone = rng.randrange(DRONES) if kind.startswith(PER_DRONE) else None
        for_good = kind == "drone.kill" and rng.random() < FOR_GOOD_P
        level = 0.0
        if kind == "link.latency":
            level = round(rng.uniform(0.2, 1.5), 2)
        elif kind == "link.loss":
            level = round(rng.uniform(0.1, 0.4), 2)
        drawn.append(Fault(kind, at_s, duration_s, drone, for_good, level))
    drawn.sort(key=lambda f: f.at_s)
    return Schedule(seed, speedup, loops, tuple(drawn))


# -- the link ----------------------------------------------------------------------------------


class ChaosLink(LinkProxy):
    """A drone's bridge link (support/link_proxy.py's emulation of what TCP makes of latency and
    loss), whose ``latency_s`` and ``loss`` may change while it runs, and which can be
    partitioned: nothing crosses while it is (data waits, as TCP's retransmissions would, and new
    connections are accepted but reach the ground broker only once it heals); a side that gives
    up meanwhile (the bridge's or the broker's keep-alive) aborts both."""

    def __init__(self, target_port: int, seed: int) -> None:
        super().__init__(target_port, latency_s=0.0, loss=0.0, seed=seed)
        self._healed: asyncio.Event | None = None

    def set(self, *, latency_s: float = 0.0, loss: float = 0.0) -> None:
        self.latency_s, self.loss = latency_s, loss

    def partition(self, on: bool) -> None:
        def flip() -> None:
            assert self._healed is not None
            if on:
                self._healed.clear()
            else:
                self._healed.set()

        self._loop.call_soon_threadsafe(flip)

    @property
    def partitioned(self) -> bool:
        return self._healed is not None and not self._healed.is_set()

    async def _listen(self) -> None:
        self._healed = asyncio.Event()
        self._healed.set()
        await super()._listen()

    async def _connection(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter):
        assert self._healed is not None
        try:
            await self._healed.wait()
            up_reader, up_writer = await asyncio.open_connection("127.0.0.1", self.target_port)
        except OSError:
            writer.close()
            return
        pumps = [
            asyncio.create_task(self._pump(reader, up_writer)),
            asyncio.create_task(self._pump(up_reader, writer)),
        ]
        await asyncio.wait(pumps, return_when=asyncio.FIRST_COMPLETED)
        for task in pumps:
            task.cancel()
        for w in (writer, up_writer):
            with contextlib.suppress(Exception):
                if self.partitioned:
                    w.transport.abort()
                else:
                    w.close()

    async def _pump(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        assert self._healed is not None
        healed = self._healed
        queue: asyncio.Queue[tuple[float, bytes]] = asyncio.Queue()

        async def deliver() -> None:
            while True:
                due, data = await queue.get()
                await asyncio.sleep(max(0.0, due - time.monotonic()))
                await healed.wait()
                writer.write(data)
                await writer.drain()

        sender = asyncio.create_task(deliver())
        last_due = 0.0
        try:
            with contextlib.suppress(ConnectionError):
                while data := await reader.read(65536):
                    last_due = max(last_due, time.monotonic() + self._delay())
                    queue.put_nowait((last_due, data))
            while not queue.empty() and not self.partitioned and not sender.done():
                await asyncio.sleep(0.05)
        finally:
            sender.cancel()


# -- the rig -----------------------------------------------------------------------------------


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


@dataclass
class Part:
    """A supervised process: started again when it exits while nobody meant it to (as systemd's
    ``Restart=always`` would), each such exit noted."""

    name: str
    cmd: list[str]
    log: Path
    proc: subprocess.Popen[bytes] | None = None
    down: bool = False  # killed on purpose and not yet started again
    gone: bool = False  # killed for good
    stopped: bool = False  # SIGSTOPped
    exits: list[str] = field(default_factory=list)

    def start(self) -> None:
        with open(self.log, "ab") as out:
            self.proc = subprocess.Popen(self.cmd, stdout=out, stderr=subprocess.STDOUT)
        self.down = False

    def signal(self, sig: int) -> None:
        if self.proc is not None and self.proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                self.proc.send_signal(sig)

    def kill(self) -> None:
        self.down = True
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self.stopped = False

    def end(self) -> None:
        self.gone = True
        proc, self.proc = self.proc, None
        if proc is not None and proc.poll() is None:
            proc.send_signal(signal.SIGCONT)
            proc.terminate()
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


class BrokerPart:
    """A Mosquitto of the rig (support/brokers.Mosquitto) with its own folder (its persistence
    file), killed, stopped and started again on the same port."""

    def __init__(self, name: str, folder: Path, extra_conf: str = "") -> None:
        folder.mkdir(parents=True, exist_ok=True)
        self.name = name
        self.broker = Mosquitto(folder, extra_conf, persistent=True)
        self.down = False
        self.stopped = False
        self.exits: list[str] = []

    @property
    def port(self) -> int:
        return self.broker.port

    def start(self) -> None:
        for attempt in range(20):
            try:
                self.broker.start()
                break
            except (RuntimeError, TimeoutError):  # the port not free again yet
                self.broker.stop(kill=True)
                if attempt == 19:
                    raise
                time.sleep(0.5)
        self.down = False

    def signal(self, sig: int) -> None:
        proc = self.broker.proc
        if proc is not None and proc.poll() is None:
            proc.send_signal(sig)

    def kill(self) -> None:
        self.down = True
        self.broker.stop(kill=True)
        self.stopped = False

    def end(self) -> None:
        self.signal(signal.SIGCONT)
        self.broker.stop()


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


# -- a run -------------------------------------------------------------------------------------

ENDED = ("completed", "failed", "stopped")


@dataclass
class Outcome:
    schedule: Schedule
    drones: list[str]
    checks: dict[str, str]  # check -> "ok" | "n/a" | "FAIL: ..."
    state: str
    wall_s: float
    mission_id: str | None = None
    details: dict[str, Any] = field(default_factory=dict)
    events: list[str] = field(default_factory=list)
    folder: str = ""

    @property
    def failed(self) -> list[str]:
        return [name for name, result in self.checks.items() if result.startswith("FAIL")]

    def as_json(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        data["schedule"]["faults"] = [dataclasses.asdict(f) for f in self.schedule.faults]
        return data


CHECKS = ("reports", "once", "ended", "home", "apart")


#: Wall seconds the checks wait at most for reports still on their way (a bridge made again).
REPORTS_WAIT_S = 60.0


def run(schedule: Schedule, tmp: Path, *, settle_s: float = 6.0) -> Outcome:
    """Fly the area through ``schedule``'s faults in a fresh topology under ``tmp``; the checks."""
    tmp.mkdir(parents=True, exist_ok=True)
    began = time.monotonic()
    rig = Rig(tmp, schedule)
    outcome = Outcome(schedule, rig.drones, {}, "not started", 0.0, folder=str(tmp))
    try:
        rig.start()
        # Planning runs in a niced worker process: on a loaded machine it takes its time.
        created = rig.api.post(
            "/api/v1/missions",
            params={"start": "true"},
            json=area_spec(rig.drones),
            timeout=240,
        )
        if created.status_code != 201:
            outcome.state = f"refused {created.status_code}"
            outcome.checks = {c: f"FAIL: mission refused: {created.text[:200]}" for c in CHECKS}
            return outcome
        mission_id = created.json()["mission_id"]
        outcome.mission_id = mission_id
        start = time.time()
        rig.note(f"mission {mission_id} started")
        rig.apply(start)
        last_end = max((f.at_s + f.duration_s for f in schedule.faults), default=0.0)
        deadline = start + last_end + max(60.0, 3 * mission_wall_s(schedule.speedup))
        detail = wait_ended(rig, mission_id, deadline)
        rig.note(f"mission {detail.get('state')}")
        while not rig.faults_done() and time.time() < start + last_end + 30:
            time.sleep(0.2)
        time.sleep(settle_s)
        detail = fetch(rig, f"/api/v1/missions/{mission_id}", 30) or detail
        # Every report must end up in the record: a drone whose broker was stopped comes back
        # once its bridge is made again (Mosquitto tries again after some seconds), and its
        # queued reports follow. Judged when they are all in, or after REPORTS_WAIT_S.
        until = time.time() + REPORTS_WAIT_S
        while detail.get("legs") and time.time() < until:
            legs = {leg["leg_id"]: leg for leg in detail["legs"]}
            if check_reports(detail, legs, drone_reports(rig, mission_id), {}) == "ok":
                break
            time.sleep(2.0)
            detail = fetch(rig, f"/api/v1/missions/{mission_id}", 30) or detail
        outcome.state = detail.get("state", "unknown")
        outcome.checks, outcome.details = judge(rig, detail, start)
    except Exception as exc:
        outcome.state = f"error: {exc!r}"[:300]
        outcome.checks = {c: f"FAIL: run error {exc!r}"[:300] for c in CHECKS}
    finally:
        with contextlib.suppress(Exception):
            rig.close()
        outcome.events = [f"{t - rig.t0:7.1f}s {what}" for t, what in rig.events]
        outcome.wall_s = time.monotonic() - began
        with contextlib.suppress(Exception):
            (tmp / "outcome.json").write_text(json.dumps(outcome.as_json(), indent=1, default=str))
    return outcome


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


def wait_ended(rig: Rig, mission_id: str, deadline: float) -> dict[str, Any]:
    detail: dict[str, Any] = {}
    while time.time() < deadline:
        with contextlib.suppress(httpx.HTTPError, ValueError):
            answer = rig.api.get(f"/api/v1/missions/{mission_id}", timeout=5)
            if answer.status_code == 200:
                detail = answer.json()
                if detail["state"] in ENDED:
                    return detail
        time.sleep(0.5)
    return detail


# -- the checks --------------------------------------------------------------------------------


def judge(rig: Rig, detail: dict[str, Any], start: float) -> tuple[dict[str, str], dict]:
    mission_id = detail["mission_id"]
    with contextlib.suppress(OSError):
        (rig.tmp / "mission.json").write_text(json.dumps(detail, indent=1))
    legs = {leg["leg_id"]: leg for leg in detail["legs"]}
    sent = drone_reports(rig, mission_id)
    details: dict[str, Any] = {
        "handovers": [
            {k: h.get(k) for k in ("from_drone", "to_drone", "reason", "committed")}
            for h in detail["handovers"]
        ],
        "error": detail.get("error"),
        "steps_done": detail.get("steps_done"),
        "steps": detail.get("steps"),
    }
    checks = {
        "reports": check_reports(detail, legs, sent, details),
        "once": check_once(detail, legs, sent, details),
        "ended": check_ended(rig, detail, details),
        "home": check_home(rig, detail, details),
        "apart": check_apart(rig, details),
    }
    sep = fetch(rig, "/api/v1/separation", 5)
    if sep is not None:
        details["ground_separation"] = sep
    details["exits"] = {
        name: part.exits for name, part in {**rig.parts, **rig.brokers}.items() if part.exits
    }
    details["tracebacks"] = {
        part.name: text.count("Traceback")
        for part in rig.parts.values()
        if part.log.exists() and (text := part.log.read_text(errors="replace")).count("Traceback")
    }
    return checks, details


def drone_reports(rig: Rig, mission_id: str) -> dict[str, dict[tuple[str, int], dict]]:
    """Per drone, the reports it sent for ``mission_id``'s legs: (leg id, seq) -> report.

    A drone still running keeps every report in its ``reports.db`` and sends it when asked; a
    drone killed for good sent only what its logger saw reach its broker."""
    out: dict[str, dict[tuple[str, int], dict]] = {}
    for drone_id in rig.drones:
        found: dict[tuple[str, int], dict] = {}
        gone = rig.parts[drone_id].gone
        if not gone:
            db = rig.tmp / drone_id / "state" / "reports.db"
            if db.exists():
                with contextlib.closing(sqlite3.connect(f"file:{db}?mode=ro", uri=True)) as c:
                    for leg_id, seq, body in c.execute(
                        "SELECT mission_id, seq, body FROM reports WHERE mission_id LIKE ?",
                        (f"{mission_id}.%",),
                    ):
                        found[(leg_id, seq)] = json.loads(body)
        for line in log_lines(rig, drone_id):
            payload = line.get("payload")
            if not line.get("topic", "").endswith("/mission/out") or not isinstance(payload, dict):
                continue
            leg_id, seq = payload.get("mission_id", ""), payload.get("seq")
            if leg_id.startswith(f"{mission_id}.") and seq is not None:
                found.setdefault((leg_id, seq), payload)
        out[drone_id] = found
    return out


def log_lines(rig: Rig, drone_id: str) -> Iterator[dict[str, Any]]:
    folder = rig.tmp / drone_id / "logs"
    files = sorted(folder.glob(f"{drone_id}.jsonl*"), key=lambda p: p.name, reverse=True)
    for path in files:  # .jsonl.5 ... .jsonl.1, .jsonl: oldest first
        for raw in path.read_bytes().splitlines():
            with contextlib.suppress(ValueError):
                yield json.loads(raw)


def check_reports(detail: dict, legs: dict, sent: dict, details: dict) -> str:
    missing, late = [], []
    ended = detail.get("ended_at")
    for drone_id, reports in sent.items():
        for (leg_id, seq), body in sorted(reports.items()):
            leg = legs.get(leg_id)
            if leg is not None and seq in leg["seqs"]:
                continue
            what = f"{drone_id} {leg_id}#{seq} {body.get('event')}"
            if body.get("step_index") is not None:
                what += f" step {body['step_index']}"
            if leg is None:
                missing.append(what + " (a leg the record does not have)")
            elif leg["role"] == "recovery" and ended and body.get("timestamp", 0) >= ended - 1:
                late.append(what)
            else:
                missing.append(what)
    details["reports_sent"] = sum(len(r) for r in sent.values())
    details["reports_missing"] = missing
    details["reports_late_recovery"] = late
    if missing:
        return f"FAIL: {len(missing)} of {details['reports_sent']} missing"
    return "ok" + (f" ({len(late)} late)" if late else "")


def flown_steps(detail: dict, legs: dict, sent: dict) -> dict[int, list[str]]:
    """Global work index -> the legs (``drone/leg``) that reported its step done, by the
    drones' own reports and the planner's record together."""
    flown: dict[int, set[str]] = defaultdict(set)
    for reports in sent.values():
        for (leg_id, _seq), body in reports.items():
            leg = legs.get(leg_id)
            if leg is None or body.get("event") != "step" or body.get("step_index") is None:
                continue
            k = body["step_index"] - len(leg["prefix"])
            if 0 <= k < len(leg["indices"]):
                flown[leg["indices"][k]].add(f"{leg['drone_id']}/{leg_id}")
    for leg in legs.values():
        for report in leg["reports"]:
            if report.get("index") is not None:
                flown[report["index"]].add(f"{leg['drone_id']}/{leg['leg_id']}")
    return {i: sorted(v) for i, v in flown.items()}


def check_once(detail: dict, legs: dict, sent: dict, details: dict) -> str:
    work = detail["work"]
    required = set(detail["required"] if detail.get("required") is not None else range(len(work)))
    waypoints = [
        i for i, s in enumerate(work) if s.get("command") == "wait_for_flight" and i in required
    ]
    flown = flown_steps(detail, legs, sent)
    twice = {i: flown[i] for i in waypoints if len(flown.get(i, [])) > 1}
    never = [i for i in waypoints if not flown.get(i)]
    by_two = {
        i: who
        for i, who in flown.items()
        if len({w.split("/")[0] for w in who}) > 1 and i not in twice
    }
    details["waypoints"] = len(waypoints)
    details["waypoints_twice"] = twice
    details["waypoints_never"] = never
    details["steps_by_two_drones"] = by_two  # a half-flown navigate may be flown again
    problems = []
    if twice:
        problems.append(f"{len(twice)} reached twice")
    if never and detail["state"] == "completed":
        problems.append(f"{len(never)} never reached")
    return "FAIL: " + ", ".join(problems) if problems else "ok"


def check_ended(rig: Rig, detail: dict, details: dict) -> str:
    could = any(not rig.parts[d].gone for d in rig.drones)
    state = detail["state"]
    if state == "completed" and detail.get("ended_at"):
        return "ok"
    if state in ENDED and not detail.get("ended_at"):
        return f"FAIL: {state} without ended_at"
    if not could:
        return "n/a"
    return f"FAIL: {state}: {(detail.get('error') or '')[:120]}"


def check_home(rig: Rig, detail: dict, details: dict) -> str:
    """Each recovery leg (a drone sent home) needs a cause."""
    by_leg = {h.get("recovery_leg"): h for h in detail["handovers"] if h.get("recovery_leg")}
    called_off = {h.get("to_drone") for h in detail.get("takeovers_cancelled", [])}
    critical = {a.get("drone_id") for a in detail["alarms"] if a.get("level") == "CRITICAL"}
    homes, bad = [], []
    for leg in detail["legs"]:
        if leg["role"] != "recovery":
            continue
        drone_id = leg["drone_id"]
        handover = by_leg.get(leg["leg_id"]) or next(
            (h for h in detail["handovers"] if h["from_drone"] == drone_id), None
        )
        sent_at = leg.get("sent_at") or 0.0
        if handover is not None:
            own = [(a, b) for a, b in rig.touched.get(drone_id, []) if a <= sent_at]
            cause = "alarm" if drone_id in critical else ("own fault" if own else None)
            what = f"{drone_id} ({handover['reason'][:80]})"
        elif drone_id in called_off:
            cause, what = "takeover called off", f"{drone_id} (replacement called off)"
        else:
            cause, what = None, f"{drone_id} (no handover)"
        homes.append(f"{what}: {cause or 'NO CAUSE'}")
        if cause is None:
            bad.append(what)
    details["sent_home"] = homes
    return f"FAIL: {'; '.join(bad)}"[:300] if bad else "ok"


def positions(rig: Rig, drone_id: str) -> list[tuple[float, float, float, float, bool]]:
    """(wall time, lat, lon, alt, in the air) of each telemetry message in the drone's log."""
    out = []
    in_air = False
    for line in log_lines(rig, drone_id):
        payload = line.get("payload")
        if not line.get("topic", "").endswith("/telemetry/out") or not isinstance(payload, dict):
            continue
        f = payload.get("fields") or {}
        if "lat" not in f or "lon" not in f:
            continue
        if "in_air" in f:
            in_air = bool(f["in_air"])
        elif "relative_alt_m" in f:
            in_air = f["relative_alt_m"] > 0.5
        out.append((payload.get("timestamp", line["t"]), f["lat"], f["lon"], f["alt_m"], in_air))
    out.sort()
    return out


def flat_m(lat_a: float, lon_a: float, lat_b: float, lon_b: float) -> float:
    """Horizontal metres between two near points (the local tangent plane: a millimetre's error
    at a hundred metres)."""
    north = math.radians(lat_b - lat_a) * 6_367_449.0
    east = math.radians(lon_b - lon_a) * 6_378_137.0 * math.cos(math.radians(lat_a))
    return math.hypot(north, east)


def check_apart(rig: Rig, details: dict, max_gap_s: float = 1.0) -> str:
    """Closest approach of every pair, sampled every 0.1 s where both have a position from
    within ``max_gap_s`` (a drone whose process was stopped holds its last one: its simulated
    vehicle stood still)."""

    def known(drone_id: str, sample_t: float, t: float) -> bool:
        if t - sample_t <= max_gap_s:
            return True
        return any(a - max_gap_s <= sample_t and t <= b for a, b in rig.frozen.get(drone_id, []))

    tracks = {d: positions(rig, d) for d in rig.drones}
    closest: tuple[float, str, float] | None = None
    breaches = []
    names = rig.drones
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            ta, tb = tracks[a], tracks[b]
            if not ta or not tb:
                continue
            t, end = max(ta[0][0], tb[0][0]), min(ta[-1][0], tb[-1][0])
            ia = ib = 0
            while t <= end:
                while ia + 1 < len(ta) and ta[ia + 1][0] <= t:
                    ia += 1
                while ib + 1 < len(tb) and tb[ib + 1][0] <= t:
                    ib += 1
                pa, pb = ta[ia], tb[ib]
                if known(a, pa[0], t) and known(b, pb[0], t) and pa[4] and pb[4]:
                    h = flat_m(pa[1], pa[2], pb[1], pb[2])
                    v = abs(pa[3] - pb[3])
                    d3 = math.hypot(h, v)
                    if closest is None or d3 < closest[0]:
                        closest = (d3, f"{a}-{b}", t)
                    if h < SEPARATION_H_M and v < SEPARATION_V_M:
                        breaches.append((t, a, b, round(h, 2), round(v, 2)))
                t += 0.1
    if closest is not None:
        details["closest_m"] = round(closest[0], 2)
        details["closest_pair"] = closest[1]
        details["closest_at_s"] = round(closest[2] - rig.t0, 1)
    details["breaches"] = [(round(t - rig.t0, 1), a, b, h, v) for t, a, b, h, v in breaches[:20]]
    if breaches:
        first = breaches[0]
        return f"FAIL: {first[1]}-{first[2]} {first[3]} m apart ({first[4]} m vertically)"
    return "ok" if closest is not None else "n/a"


# -- the table ---------------------------------------------------------------------------------


def table(outcomes: list[Outcome]) -> str:
    head = ["seed", "x", "busy", "faults", *CHECKS, "mission", "wall s"]
    rows = [head]
    for o in outcomes:
        s = o.schedule
        cells = [
            str(s.seed),
            f"{s.speedup:g}",
            str(s.busy),
            " ".join(f.label(o.drones) for f in s.faults) or "none",
            *(short(o.checks.get(c, "-")) for c in CHECKS),
            o.state[:24],
            f"{o.wall_s:.0f}",
        ]
        rows.append(cells)
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def short(result: str) -> str:
    if result.startswith("FAIL"):
        return "FAIL"
    return result.split(" ")[0]


def failures(outcomes: list[Outcome]) -> str:
    """Each failed check with what failed, and the run's events, for the report."""
    out = []
    for o in outcomes:
        if not o.failed:
            continue
        out.append(f"seed {o.schedule.seed} ({o.folder}): mission {o.mission_id} {o.state}")
        for name in o.failed:
            out.append(f"  {name}: {o.checks[name]}")
        for key in ("reports_missing", "waypoints_twice", "breaches", "sent_home", "error"):
            if o.details.get(key):
                out.append(f"  {key}: {str(o.details[key])[:600]}")
        out.extend(f"  | {e}" for e in o.events)
    return "\n".join(out)
