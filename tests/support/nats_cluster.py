"""A 3-node NATS cluster for tests (issue 27): each node a ``nats-server`` process with the
configuration the project generates (messaging/nats_config.py: cluster routes to the others, the
MQTT streams replicated on ``stream_replicas`` nodes), on free loopback ports. Anonymous MQTT
clients are allowed everything, as the ``embedded_broker`` fixture's; ``users`` log in with their
rights, over MQTT or over NATS's own client port (``node.nats_url``: the grounds' shared
telemetry ingestion, ground/telemetry/shared_ingest.py)."""

from __future__ import annotations

import contextlib
import shutil
import socket
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from dronefleet.messaging.broker_users import BrokerUsers
from dronefleet.messaging.nats_broker import find_nats_server
from dronefleet.messaging.nats_config import NatsCluster, nats_config
from dronefleet.messaging.ports import free_port
from dronefleet.messaging.url import BrokerUrl


class ClusterNode:
    def __init__(self, folder: Path, name: str, mqtt_port: int, route_port: int) -> None:
        self.folder, self.name = folder, name
        self.mqtt_port, self.route_port = mqtt_port, route_port
        self.nats_port = free_port()
        self.proc: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> BrokerUrl:
        return BrokerUrl("127.0.0.1", self.mqtt_port)

    @property
    def nats_url(self) -> str:
        return f"nats://127.0.0.1:{self.nats_port}"

    def start(self) -> None:
        out = open(self.folder / "nats-server.log", "ab")  # noqa: SIM115 - the process's
        self.proc = subprocess.Popen(
            [str(find_nats_server()), "-c", str(self.folder / "nats.conf")],
            stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, cwd=self.folder,
        )  # fmt: skip
        out.close()

    def kill(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


def wait_listening(node: ClusterNode, deadline: float) -> None:
    """Until ``node`` listens for MQTT; a node that exited, or is still not listening at the
    deadline, is reported with the end of its log (the why of a failed start)."""
    while True:
        with contextlib.suppress(OSError):
            socket.create_connection(("127.0.0.1", node.mqtt_port), timeout=0.5).close()
            return
        exited = node.proc is not None and node.proc.poll() is not None
        if exited or time.monotonic() > deadline:
            log = (node.folder / "nats-server.log").read_text(errors="replace")[-3000:]
            state = f"exited {node.proc.returncode}" if exited and node.proc else "not listening"
            raise RuntimeError(f"NATS node {node.name} {state} on {node.mqtt_port}:\n{log}")
        time.sleep(0.05)


def wait_sessions(node: ClusterNode, deadline: float) -> None:
    """Until ``node`` accepts an MQTT session (CONNACK 0, persistent session). A node listens
    at once but keeps its MQTT sessions in JetStream, which answers only once the cluster has
    elected its leader: seconds, more on a loaded host, which outlasted the ground's 10 s wait
    for its first link when replicas were started right away."""
    import paho.mqtt.client as mqtt  # the project's own client retries; this asks once per try

    while True:
        probe = mqtt.Client(
            mqtt.CallbackAPIVersion.VERSION2, client_id=f"probe-{node.name}", clean_session=False
        )
        with contextlib.suppress(OSError):
            probe.connect("127.0.0.1", node.mqtt_port, keepalive=10)
            until = time.monotonic() + 2.0
            while not probe.is_connected() and time.monotonic() < until:
                probe.loop(timeout=0.1)
        accepted = probe.is_connected()
        probe.disconnect()
        if accepted:
            return
        if time.monotonic() > deadline:
            raise TimeoutError(f"NATS node {node.name} accepted no MQTT session in time")
        time.sleep(0.5)


@contextlib.contextmanager
def nats_cluster(nodes: int = 3, users: BrokerUsers | None = None) -> Iterator[list[ClusterNode]]:
    root = Path(tempfile.mkdtemp(prefix="dronefleet-nats-cluster-"))
    route_ports = [free_port() for _ in range(nodes)]
    routes = tuple(f"nats-route://127.0.0.1:{p}" for p in route_ports)
    members = []
    for i, route_port in enumerate(route_ports):
        folder = root / f"n{i}"
        folder.mkdir()
        node = ClusterNode(folder, f"n{i}", free_port(), route_port)
        cluster = NatsCluster(
            name="dronefleet-test",
            server_name=node.name,
            host="127.0.0.1",
            port=route_port,
            routes=tuple(r for r in routes if not r.endswith(f":{route_port}")),
            stream_replicas=min(3, nodes),
        )
        text = nats_config(
            users if users is not None else BrokerUsers(),
            mqtt_host="127.0.0.1",
            mqtt_port=node.mqtt_port,
            nats_port=node.nats_port,
            store_dir=str(folder / "jetstream"),
            anonymous=True,
            cluster=cluster,
        )
        (folder / "nats.conf").write_text(text)
        members.append(node)
    try:
        for node in members:
            node.start()
        deadline = time.monotonic() + 60
        for node in members:
            wait_listening(node, deadline)
        for node in members:
            wait_sessions(node, deadline)
        yield members
    finally:
        for node in members:
            node.kill()
        shutil.rmtree(root, ignore_errors=True)
