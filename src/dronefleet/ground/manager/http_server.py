"""The ground's HTTP server: uvicorn on a socket the ground binds itself (the REST API and the
web apps of :func:`~dronefleet.ground.manager.app.create_app`)."""

from __future__ import annotations

import asyncio
import logging
import socket
from collections.abc import Sequence
from typing import Any

import uvicorn

log = logging.getLogger(__name__)

#: Seconds the HTTP server may take to start before the ground gives up on it (issue 26: no
#: wait without a bound).
HTTP_START_TIMEOUT_S = 30.0


class HttpServer:
    """``port = await HttpServer(app, host, port, trusted_proxies).start()``; ``stop()``."""

    def __init__(self, app: Any, host: str, port: int, trusted_proxies: Sequence[str]) -> None:
        self.app, self.host, self.port = app, host, port
        self.trusted_proxies = list(trusted_proxies)
        self._server: uvicorn.Server | None = None
        self._task: asyncio.Task[None] | None = None

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    async def start(self) -> int:
        """Serve; the port bound (0 asks the system for a free one)."""
        # The socket is bound here, not by uvicorn, which logs a port in use and calls sys.exit:
        # ours raises OSError ("Address already in use"), which the CLI reports in one line.
        sock = socket.socket(socket.AF_INET6 if ":" in self.host else socket.AF_INET)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind((self.host, self.port))
        except OSError:
            sock.close()
            raise
        self.port = sock.getsockname()[1]
        config = uvicorn.Config(
            self.app,
            host=self.host,
            port=self.port,
            log_level="warning",
            lifespan="off",
            ws="websockets-sansio",
            timeout_graceful_shutdown=2,
            timeout_keep_alive=2,
            # uvicorn would believe X-Forwarded-For from 127.0.0.1 by default (and from whatever
            # FORWARDED_ALLOW_IPS says): only from the proxies the ground was given.
            proxy_headers=bool(self.trusted_proxies),
            forwarded_allow_ips=self.trusted_proxies or [],
        )
        server = self._server = uvicorn.Server(config)
        task = self._task = asyncio.create_task(server.serve(sockets=[sock]), name="ground:http")
        deadline = asyncio.get_running_loop().time() + HTTP_START_TIMEOUT_S
        while not server.started:
            if task.done():
                task.result()  # raises the reason (e.g. port in use)
                raise RuntimeError(f"HTTP server on {self.url} stopped at start")
            if asyncio.get_running_loop().time() > deadline:
                task.cancel()
                raise RuntimeError(
                    f"HTTP server on {self.url} not started in {HTTP_START_TIMEOUT_S:g} s"
                )
            await asyncio.sleep(0.02)
        return self.port

    async def stop(self) -> None:
        if self._server is None or self._task is None:
            return
        self._server.should_exit = True
        # asyncio.wait, not wait_for: a server that ignores cancellation must not hang us.
        done, _ = await asyncio.wait({self._task}, timeout=5.0)
        if not done:
            log.warning("HTTP server did not stop within 5 s; leaving it")
            self._task.cancel()
        self._server = self._task = None
