"""Issue 11: schemathesis over the whole published OpenAPI surface of a running ground.

A real ``dronefleet ground`` and a simulated ``dronefleet drone`` on a Mosquitto of their own;
schemathesis reads ``/openapi.json`` and, for every operation, sends requests that fit the schema
and requests that do not. Each answer must be no 5xx, a status the operation documents, and a
body that fits the documented schema. Calls are counted and printed (``-s`` shows them).

The budget is kept by examples per operation (not by time: no timed assertions), chosen so the
whole surface takes about a minute on a 2-core machine.
"""

from __future__ import annotations

import math
import re
import secrets
import time
from collections.abc import Iterator

import httpx
import pytest
import schemathesis
from hypothesis import HealthCheck, settings
from schemathesis import Case, CheckContext, Response
from schemathesis.core.parameters import ParameterLocation
from schemathesis.generation.meta import negated_parameters
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    negative_data_rejection,
    response_schema_conformance,
    status_code_conformance,
)

from dronefleet.ground.manager.app import create_app
from dronefleet.messaging.embedded import free_port
from support.brokers import mosquitto
from support.ground_procs import drone_cmd, ground_cmd, process, wait_http

pytestmark = pytest.mark.integration

DRONE = "FUZZ_1"
#: Examples per operation (about 40 operations) for the generated (fuzzing) phase.
EXAMPLES = 200
#: A drone's answer is awaited at most this long: a generated ``timeout_s`` of 300 s would spend
#: the whole budget waiting for a command the sim drone takes long to finish.
MAX_WAIT_S = 1.0


def no_server_error(ctx: CheckContext, response: Response, case: Case) -> bool | None:
    """No 5xx but 504: a drone that does not answer within the asked ``timeout_s`` is the
    documented answer to a valid request (the sim drone takes longer than 0.1 s to reset)."""
    if response.status_code >= 500 and response.status_code != 504:
        raise AssertionError(f"{case.operation.label} answered {response.status_code}")
    return None


def negative_data_refused(ctx: CheckContext, response: Response, case: Case) -> bool | None:
    """schemathesis' negative_data_rejection, with 413 among the refusals: a generated body over
    the 4 MB limit is refused before it is read (ground/manager/hardening.py, issue 12). A case
    made negative by leaving out the bearer token the schema declares is not judged: every call
    here carries the test's token (tests/integration/ground/test_http_hardening.py covers calls
    without one)."""
    if response.status_code == 413:
        return None
    if "authorization" not in {name.lower() for name in case.headers or {}}:
        return None  # the negative part is the missing token, which every call here sends
    if _only_retyped_query_strings(case):
        return None
    return negative_data_rejection(ctx, response, case)


def _only_retyped_query_strings(case: Case) -> bool:
    """A negative case whose only negative part (the Authorization header aside, which the test
    replaces) is the query, where every declared parameter
    still reads as valid once on the wire: a string parameter given a boolean, number or null
    becomes the text ``false``, ``12`` or ``null``, a valid string (``?drone=false`` names a
    drone called "false"). schemathesis' own record of what it negated says which parameters
    when it has one; anything else it negated is still judged."""
    if case.meta is None:
        return False
    negative = {loc for loc, info in case.meta.components.items() if info.mode.is_negative}
    negated = [
        (name, loc) for name, loc in negated_parameters(case.meta) if not _sent_by_the_test(name)
    ]
    if _header_negated_only_in_authorization(case):
        negative.discard(ParameterLocation.HEADER)
    if not negative:
        return True  # only the Authorization header was negated, and the test sends its own
    if negative != {ParameterLocation.QUERY} or any(
        loc != ParameterLocation.QUERY for _, loc in negated
    ):
        return False
    query = case.query or {}
    return all(
        _fits_as_text(query[p.name], p.definition.get("schema", {}))
        for p in case.operation.query
        if p.name in query
    )


def _sent_by_the_test(name: str) -> bool:
    """The Authorization header: whatever schemathesis generated for it, every call here carries
    the test's own bearer token instead (``call_and_validate(headers=...)`` replaces it)."""
    return name.lower() == "authorization"


def _header_negated_only_in_authorization(case: Case) -> bool:
    """Whether the only header a negative case can have made invalid is the one the test
    replaces: the operation declares no header parameter, so schemathesis' header negation is of
    the security scheme's Authorization."""
    return not list(case.operation.headers)


def _fits_as_text(value: object, schema: dict) -> bool:
    """Whether ``value``, as the text a URL carries, is valid for ``schema``. A list of one is
    that one on the wire (``[false]`` is sent as ``?drone=false``, as ``false`` is)."""
    if isinstance(value, list) and len(value) == 1:
        return _fits_as_text(value[0], schema)
    if isinstance(value, bool) or value is None:
        text = {True: "true", False: "false", None: "null"}[value]
    elif isinstance(value, int | float | str):
        text = str(value)
    else:
        return False  # a list or an object is not one text
    return any(_text_fits(text, option) for option in schema.get("anyOf", [schema]))


def _text_fits(text: str, option: dict) -> bool:
    kind = option.get("type")
    if kind == "string":
        return (
            option.get("minLength", 0) <= len(text) <= option.get("maxLength", len(text))
            and re.search(option.get("pattern", ""), text) is not None
        )
    if kind in ("integer", "number"):
        try:
            number = int(text) if kind == "integer" else float(text)
        except ValueError:
            return False
        low, high = option.get("minimum", -math.inf), option.get("maximum", math.inf)
        return low <= number <= high
    return False


CHECKS = [
    no_server_error,
    status_code_conformance,
    content_type_conformance,
    response_schema_conformance,
    negative_data_refused,  # a request outside the schema is refused (4xx), never served
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
    if "timeout_s" in {p.name for p in case.operation.query}:
        # Every wait for the drone is short, generated or not (see MAX_WAIT_S).
        value = (case.query or {}).get("timeout_s", MAX_WAIT_S)
        if not isinstance(value, int | float) or isinstance(value, bool) or value > MAX_WAIT_S:
            value = value if isinstance(value, str) else MAX_WAIT_S  # a bad string stays bad
        case.query = {**(case.query or {}), "timeout_s": value}
    negative = case.meta is not None and case.meta.generation.mode.is_negative
    if not negative and "drone_id" in (case.path_parameters or {}) and len(CALLS) % 2:
        # Every other valid call names the drone that is there, so commands reach a drone too.
        case.path_parameters["drone_id"] = DRONE
    CALLS.append(case.operation.label)
    case.call_and_validate(
        base_url=url, headers={"Authorization": f"Bearer {token}"}, checks=CHECKS, timeout=30
    )
