"""No token in plaintext on disk, state files the owner's only (issue 12, must-show 4 in part)."""

from __future__ import annotations

import stat

import pytest

from dronefleet import demo
from dronefleet.ground.manager.auth import TokenBook

pytestmark = pytest.mark.integration


async def test_the_ground_state_is_the_owners_only_and_holds_no_token(ground, tmp_path):
    operator = ground.operator_token
    viewer = await demo._tokens(TokenBook(ground.state), tmp_path, None)
    files = [p for p in tmp_path.rglob("*") if p.is_file()]
    assert any(p.name == "ground.db" for p in files)
    for path in files:
        if path.name.startswith("ground.db"):
            assert stat.S_IMODE(path.stat().st_mode) == 0o600, path
        data = path.read_bytes()
        for token in (operator, *viewer):
            assert token.encode() not in data, f"{token[:6]}... in plaintext in {path.name}"
