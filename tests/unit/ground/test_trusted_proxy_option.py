"""``--trusted-proxy`` on ``dronefleet ground`` and ``dronefleet demo`` (issue 25): repeatable,
an address or a network; none by default (X-Forwarded-For is then ignored)."""

from __future__ import annotations

import pytest

from dronefleet.cli import build_parser


@pytest.mark.parametrize("command", ["ground", "demo"])
def test_trusted_proxies_are_none_by_default_and_may_be_repeated(command):
    parser = build_parser()
    assert parser.parse_args([command]).trusted_proxy == []
    args = parser.parse_args(
        [command, "--trusted-proxy", "127.0.0.1", "--trusted-proxy", "10.1.2.0/24"]
    )
    assert args.trusted_proxy == ["127.0.0.1/32", "10.1.2.0/24"]


@pytest.mark.parametrize("bad", ["*", "proxy.example", "10.0.0.0/33", ""])
def test_a_trusted_proxy_is_an_address_or_a_network(bad, capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["ground", "--trusted-proxy", bad])
    assert "--trusted-proxy" in capsys.readouterr().err
