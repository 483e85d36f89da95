"""Every 2xx answer of the REST API names its schema in /openapi.json (issue 15, must-show 3).

Before, 30 of 37 2xx responses were published as untyped objects; schemathesis checks the
answers against these schemas (tests/integration/ground/test_ground_openapi_fuzz.py).
"""

from __future__ import annotations

from typing import Any

from dronefleet.ground.manager.app import create_app


def _named(schema: dict[str, Any] | None) -> bool:
    if not schema:
        return False
    if "$ref" in schema:
        return True
    if schema.get("type") == "array":
        return _named(schema.get("items"))
    for key in ("anyOf", "oneOf", "allOf"):
        if key in schema:
            return all(_named(s) or s.get("type") == "null" for s in schema[key])
    return False


def test_every_2xx_response_names_a_schema():
    spec = create_app(None).openapi()
    answers = [
        (method.upper(), path, code, response)
        for path, operations in spec["paths"].items()
        for method, operation in operations.items()
        for code, response in operation.get("responses", {}).items()
        if code.startswith("2") and code != "204"  # No Content: no body to name
    ]
    assert len(answers) >= 37
    unnamed = [
        (method, path, code)
        for method, path, code, response in answers
        if not _named(next(iter(response.get("content", {}).values()), {}).get("schema"))
    ]
    assert unnamed == []


def test_every_operation_but_the_public_ones_declares_the_bearer_scheme():
    """Issue 12: clients and fuzzers see how the API authenticates. Public: the health check,
    the web app's start-up settings (map tiles) and the seed's /control page, which asks for
    its token itself."""
    spec = create_app(None).openapi()
    schemes = spec["components"]["securitySchemes"]
    assert schemes["HTTPBearer"] == {
        "type": "http",
        "scheme": "bearer",
        "description": "an API token: `Authorization: Bearer <token>`",
    }
    open_ = {
        path
        for path, operations in spec["paths"].items()
        for operation in operations.values()
        if {"HTTPBearer": []} not in operation.get("security", [])
    }
    assert open_ == {"/api/v1/health", "/api/v1/web/config", "/control"}, open_
