"""The rig's parts: a process (a drone, the ground) or a broker, each killed, stopped, restarted."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

from support.brokers import Mosquitto


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
