"""Real brokers for tests: the embedded one, and Mosquitto started on a free port."""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

from dronefleet.messaging.embedded import free_port
from dronefleet.messaging.url import BrokerUrl
from support.processes import stop

MOSQUITTO = shutil.which("mosquitto") or "/usr/sbin/mosquitto"


def wait_port(host: str, port: int, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        with contextlib.suppress(OSError), socket.create_connection((host, port), timeout=0.5):
            return
        time.sleep(0.05)
    raise TimeoutError(f"nothing listening on {host}:{port} after {timeout_s} s")


class Mosquitto:
    """A Mosquitto of our own on a free loopback port (never assumes 1883 is free); anonymous
    clients allowed unless ``anonymous=False`` (then ``extra_conf`` names the password file).
    It can be killed (SIGKILL: nothing it held in memory survives) and started again on the
    same port with the same configuration, as the fault tests of issue 13 do."""

    def __init__(
        self,
        tmp: Path,
        extra_conf: str = "",
        port: int | None = None,
        *,
        anonymous: bool = True,
        persistent: bool = False,
    ) -> None:
        if not Path(MOSQUITTO).exists():
            raise RuntimeError(
                "mosquitto is not installed: run `make system-deps` (apt-get install mosquitto)"
            )
        self.port = port or free_port()
        self.conf = tmp / f"mosquitto-{self.port}.conf"
        # As root, Mosquitto would drop to its own user, which cannot write its log or
        # persistence file into pytest's private tmp folder: a persistent session would then
        # silently not be.
        user = "user root\n" if os.geteuid() == 0 else ""
        keep = (
            f"persistence true\npersistence_location {tmp}/\n"
            if persistent
            else "persistence false\n"
        )
        self.conf.write_text(
            f"listener {self.port} 127.0.0.1\nallow_anonymous {str(anonymous).lower()}\n"
            f"{keep}{user}set_tcp_nodelay true\n"
            f"log_dest file {tmp}/mosquitto-{self.port}.log\n{extra_conf}\n"
        )
        self.proc: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> BrokerUrl:
        return BrokerUrl("127.0.0.1", self.port)

    def start(self) -> BrokerUrl:
        self.proc = subprocess.Popen(
            [MOSQUITTO, "-c", str(self.conf)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
        )
        wait_port("127.0.0.1", self.port)
        time.sleep(0.05)
        if self.proc.poll() is not None:  # another process took the port (a restart, say)
            error = self.proc.stderr.read().decode() if self.proc.stderr else ""
            raise RuntimeError(f"mosquitto on port {self.port} exited: {error.strip()}")
        return self.url

    def stop(self, *, kill: bool = False) -> None:
        proc, self.proc = self.proc, None
        if proc is not None:
            stop(proc, sig_kill=kill)


@contextlib.contextmanager
def mosquitto(
    tmp: Path,
    extra_conf: str = "",
    port: int | None = None,
    *,
    anonymous: bool = True,
    persistent: bool = False,
) -> Iterator[BrokerUrl]:
    """A :class:`Mosquitto`, started, and stopped on the way out."""
    broker = Mosquitto(tmp, extra_conf, port, anonymous=anonymous, persistent=persistent)
    try:
        yield broker.start()
    finally:
        broker.stop()
