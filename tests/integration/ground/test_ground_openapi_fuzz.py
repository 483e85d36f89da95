"""Issue 11: schemathesis over the whole published OpenAPI surface of a running ground.

A real ``dronefleet ground`` and a simulated ``dronefleet drone`` on a Mosquitto of their own;
schemathesis reads ``/openapi.json`` and, for every operation, sends requests that fit the schema
and requests that do not. Each answer must be no 5xx, a status the operation documents, and a
body that fits the documented schema. Calls are counted and printed (``-s`` shows them).

The budget is kept by examples per operation (not by time: no timed assertions), chosen so the
whole surface takes about a minute on a 2-core machine.
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Iterator

import httpx
import pytest
import schemathesis
from ground_procs import drone_cmd, ground_cmd, process, wait_http
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    response_schema_conformance,
    status_code_conformance,
)

from dronefleet.ground.manager.app import create_app
from dronefleet.messaging.embedded import free_port
from support.brokers import mosquitto

pytestmark = pytest.mark.integration

DRONE = "FUZZ_1"
#: Examples per operation (about 40 operations) for the generated (fuzzing) phase.
EXAMPLES = 12
#: A drone's answer is awaited at most this long: a generated ``timeout_s`` of 300 s would spend
#: the whole budget waiting for a command the sim drone takes long to finish.
MAX_WAIT_S = 1.0
CHECKS = [
    not_a_server_error,
    status_code_conformance,
    content_type_conformance,
    response_schema_conformance,
]
CALLS: list[str] = []


@pytest.fixture(scope="module")
def ground(tmp_path_factory) -> Iterator[tuple[str, str]]:
    tmp = tmp_path_factory.mktemp("fuzz")
    token = secrets.token_urlsafe(16)
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    with mosquitto(tmp) as broker:
        with process(ground_cmd(broker.full(), tmp, port, token), tmp / "ground.log"):
            wait_http(url, log=tmp / "ground.log")
            with process(drone_cmd(DRONE, broker.full()), tmp / "drone.log"):
                api = httpx.Client(base_url=url, headers={"Authorization": f"Bearer {token}"})
                deadline = time.monotonic() + 30
                while api.get(f"/api/v1/drones/{DRONE}").status_code != 200:
                    assert time.monotonic() < deadline, "the sim drone never came online"
                    time.sleep(0.2)
                yield url, token
    print(f"\nschemathesis made {len(CALLS)} calls over {len(set(CALLS))} operations")


# The schema of the app's own code (what ``/openapi.json`` serves; building it needs no
# services), so the operations are known when pytest collects them, one test each.
schema = schemathesis.openapi.from_dict(create_app(None).openapi())  # type: ignore[arg-type]


@schema.parametrize()
@settings(
    max_examples=EXAMPLES,
    deadline=None,
    suppress_health_check=list(HealthCheck),
    derandomize=True,  # the same requests on every run: a failure here is reproducible
)
def test_no_operation_answers_5xx_or_off_schema(case, ground):
    url, token = ground
    if case.query and "timeout_s" in case.query:
        value = case.query["timeout_s"]
        if isinstance(value, int | float) and not isinstance(value, bool) and value > MAX_WAIT_S:
            case.query["timeout_s"] = MAX_WAIT_S
    CALLS.append(case.operation.label)
    case.call_and_validate(
        base_url=url, headers={"Authorization": f"Bearer {token}"}, checks=CHECKS, timeout=30
    )
