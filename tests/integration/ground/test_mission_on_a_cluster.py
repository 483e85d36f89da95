"""A fleet on a broker cluster flies through the loss of its leading ground and of a broker node
(issue 27, item 3). Real processes, as they are deployed: a 3-node NATS cluster
(tests/support/nats_cluster.py), the machine's PostgreSQL as the shared state, two
``dronefleet ground`` replicas and three ``dronefleet drone --fc sim``, every one of them given
the three nodes (``mqtt://a,b,c``) in a different order, so each starts on another node.

Three drones fly an area mission given over REST. Mid-mission the replica running the Mission
Planner is killed (SIGKILL: it gives nothing back) and the other takes its lease; then the
broker node the first drone and the first replica started on is killed. The mission must
complete with every waypoint flown once, on its first three legs (nobody replaced or sent home
for it), with two busy loops beside it on this machine's two cores.
"""

from __future__ import annotations

import os
import secrets
import signal
import time

import httpx
import pytest

from dronefleet.experiments import scenarios
from dronefleet.ground.lease import LEASE_S, RENEW_S
from dronefleet.messaging.embedded import free_port
from support.missions import flown_as_planned
from support.nats_cluster import nats_cluster
from support.postgres import fresh_database
from support.processes import dronefleet, process

from .test_ground_stall import Watch, busy_cores
from .test_one_ground_per_broker import lease_holder

pytestmark = pytest.mark.integration

SPEEDUP = 3.0
HOMES = {
    "CLUSTER_1": "40.63,-8.659,10",
    "CLUSTER_2": "40.63,-8.6588,10",
    "CLUSTER_3": "40.6301,-8.6586,10",
}
ENDED = ("completed", "failed", "aborted")


def nodes_from(ports: list[int], first: int) -> str:
    """The cluster's URL listing every node, starting at ``ports[first]``."""
    turn = ports[first:] + ports[:first]
    return "mqtt://" + ",".join(f"127.0.0.1:{p}" for p in turn)


def status(http: httpx.Client, path: str) -> int:
    try:
        return http.get(path).status_code
    except httpx.HTTPError:
        return 0


@pytest.mark.parametrize(
    "sharing",
    [(), ("--partition-fleet",)],
    ids=["whole-stream", "partitioned"],
)
def test_a_mission_flies_through_the_leaders_death_and_a_broker_nodes(tmp_path, sharing):
    """Partitioned (ground/partition.py), the leader killed also owned some drones: the other
    takes their telemetry once its row expires, and the planner sees them meanwhile as its
    last picture said."""
    token = secrets.token_urlsafe(16)
    area = {"polygon": scenarios.rectangle(20, -10, 50, 60), "spacing_m": 10, "altitude_m": 15}
    spec = {"name": "cluster", "area": area, "drones": list(HOMES)}
    with nats_cluster(3) as cluster, fresh_database() as state:
        ports = [node.mqtt_port for node in cluster]
        http_ports = [free_port(), free_port()]
        grounds = [
            dronefleet(
                "-v", "ground", "--broker", nodes_from(ports, i), "--state", state,
                "--store", f"sqlite:///{tmp_path}/telemetry-{i}.db",
                "--photo-dir", str(tmp_path / f"photos-{i}"),
                "--http", f"127.0.0.1:{http_ports[i]}", f"--token={token}", *sharing,
            )
            for i in range(2)
        ]  # fmt: skip
        drones = [
            dronefleet(
                "-v", "drone", "--id", drone_id, "--broker", nodes_from(ports, i), "--fc", "sim",
                "--home", home, "--speedup", str(SPEEDUP),
            )
            for i, (drone_id, home) in enumerate(HOMES.items())
        ]  # fmt: skip
        apis = [
            httpx.Client(
                base_url=f"http://127.0.0.1:{p}",
                headers={"Authorization": f"Bearer {token}"},
                timeout=30,
            )
            for p in http_ports
        ]
        with (
            process(grounds[0], tmp_path / "ground-0.log") as ground_0,
            process(grounds[1], tmp_path / "ground-1.log") as ground_1,
            process(drones[0], tmp_path / "d1.log") as drone_1,
            process(drones[1], tmp_path / "d2.log") as drone_2,
            process(drones[2], tmp_path / "d3.log") as drone_3,
        ):
            started = (ground_0, ground_1, drone_1, drone_2, drone_3)
            # Start-up is bounded by imports and the cluster's JetStream election on a loaded
            # host, not by anything measured here.
            deadline = time.monotonic() + 180
            while sorted(status(api, "/api/v1/missions") for api in apis) != [200, 503]:
                exits = [proc.poll() for proc in started]
                assert exits == [None] * 5, f"a replica or a drone exited at start-up: {exits}"
                assert time.monotonic() < deadline, "not one leader and one standby"
                time.sleep(0.2)
            lead = 0 if status(apis[0], "/api/v1/missions") == 200 else 1
            leader, standby = (ground_0, ground_1)[lead], apis[1 - lead]
            for api in apis:  # both replicas hear every drone, whichever node it is on
                for drone_id in HOMES:
                    while status(api, f"/api/v1/drones/{drone_id}") != 200:
                        exits = [proc.poll() for proc in started]
                        assert exits == [None] * 5, f"exited at start-up: {exits}"
                        assert time.monotonic() < deadline, f"{drone_id} never heard"
                        time.sleep(0.2)
            time.sleep(3.0)  # the Identifier learns each drone's clock rate
            if sharing:  # every drone owned by one replica of the two
                parts = [api.get("/api/v1/health").json()["partition"] for api in apis]
                assert [p["replicas"] for p in parts] == [2, 2], parts
                assert sum(p["own"] for p in parts) == len(HOMES), parts
            created = apis[lead].post("/api/v1/missions", params={"start": "true"}, json=spec)
            assert created.status_code == 201, created.text
            mission_id = created.json()["mission_id"]
            path = f"/api/v1/missions/{mission_id}"

            def steps_done(api: httpx.Client) -> int:
                return int(api.get(path).json()["steps_done"])

            with busy_cores():
                with Watch(str(standby.base_url), token) as through_takeover:
                    deadline = time.monotonic() + 120
                    while steps_done(apis[lead]) < 4:
                        assert time.monotonic() < deadline, "the mission did not get going"
                        time.sleep(0.2)
                    holder = lease_holder(state)
                    os.kill(leader.pid, signal.SIGKILL)
                    killed = time.monotonic()
                    while lease_holder(state) in (holder, None):
                        assert time.monotonic() - killed < 30, "the standby took no lease"
                        time.sleep(0.05)
                    took = time.monotonic() - killed
                    while status(standby, path) != 200:
                        assert time.monotonic() - killed < 60, "the standby did not lead"
                        time.sleep(0.05)
                    serving = time.monotonic() - killed
                    done_at_kill = steps_done(standby)
                    deadline = time.monotonic() + 120
                    while steps_done(standby) < done_at_kill + 3:
                        assert time.monotonic() < deadline, "the mission stopped after it"
                        time.sleep(0.2)
                node_killed_at = steps_done(standby)
                with Watch(str(standby.base_url), token) as through_node_loss:
                    cluster[0].kill()  # the first node of CLUSTER_1 and of ground 0
                    deadline = time.monotonic() + 600
                    while (detail := standby.get(path).json())["state"] not in ENDED:
                        assert time.monotonic() < deadline, f"mission still {detail['state']}"
                        time.sleep(0.5)
                    time.sleep(2.0)  # the watch sees the drones after the end too
                fleet = {d["drone_id"]: d["status"] for d in standby.get("/api/v1/drones").json()}
                part = standby.get("/api/v1/health").json()["partition"]
        for api in apis:
            api.close()

    print(
        f"lease taken {took:.2f} s and missions served {serving:.2f} s after the leader's kill;"
        f" {done_at_kill} steps done then, {node_killed_at} when a broker node was killed,"
        f" {detail['steps_done']} of {detail['steps']} at the end"
    )
    assert took < LEASE_S + RENEW_S + 1.0  # a lease, a claim, and a poll
    flown_as_planned(detail)
    # Nobody is taken for lost through the takeover, nor through the broker node's death. That
    # death cuts its drones off until they have a link to another node, which waits for the
    # cluster to elect new leaders for the MQTT streams the dead node led, and may cut drones on
    # the other nodes meanwhile (back 9-23 s after the kill on a loaded host): the ground watches
    # every node and does not count a failover's silence as the drones' (messaging/node_watch.py;
    # before, one drone or another was shown lost, or confirmed lost and its work offered).
    assert all(seen <= {"online"} for seen in through_takeover.seen.values()), through_takeover.seen
    node_loss = through_node_loss.seen
    assert all(seen <= {"online"} for seen in node_loss.values()), node_loss
    seen = {d: sorted(through_node_loss.seen[d]) for d in HOMES}
    print(f"statuses seen through the node's loss: {seen}")
    assert fleet == dict.fromkeys(HOMES, "online"), fleet
    if sharing:  # the survivor took the killed replica's drones
        assert part["replicas"] == 1 and part["own"] == len(HOMES), part
