"""``dronefleet experiment`` fails in one line (issue 9): never a traceback, and ``--json`` always
prints one result object, with ``"error"`` and the scenario's state when the run failed."""

from __future__ import annotations

import json

from dronefleet import cli
from dronefleet.experiments import scenarios


async def _no_expansion(h, strategy):  # a scenario that breaks the way collab once did at 100x
    await h.add_drone("QUAD_A", scenarios.NED(0, 0))
    return [][0]


def test_a_failed_experiment_prints_one_json_object_with_the_error(monkeypatch, capsys):
    monkeypatch.setitem(scenarios.SCENARIOS, "collab", _no_expansion)
    rc = cli.main(["experiment", "collab", "--json"])
    out, err = capsys.readouterr()
    assert rc == 1
    (line,) = out.strip().splitlines()
    result = json.loads(line)
    assert result["experiment"] == "collab" and result["strategy"] == "ours"
    assert "collab (ours) failed: list index out of range" in result["error"]
    assert "at vehicle t=" in result["error"] and "missions: none" in result["error"]
    assert "Traceback" not in out + err


def test_a_failed_experiment_says_so_in_one_line_without_json(monkeypatch, capsys):
    monkeypatch.setitem(scenarios.SCENARIOS, "collab", _no_expansion)
    assert cli.main(["experiment", "collab", "--speedup", "max"]) == 1
    out, err = capsys.readouterr()
    lines = [line for line in err.splitlines() if line.startswith("dronefleet experiment:")]
    assert len(lines) == 1 and "list index out of range" in lines[0]
    assert "Traceback" not in out + err
