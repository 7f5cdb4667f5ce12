"""``relmogen analyse episodes``: a policy's episodes one by one, under other settings."""

import json
from pathlib import Path

import pytest

from relmogen.analysis.episodes import normalised_reason, parse_assignments, summarise_traces
from relmogen.cli import main

SHIPPED = Path(__file__).resolve().parents[2] / "relmogen" / "policies" / "PushDoorNav-relmogen-r"


def test_reasons_lose_their_numbers_and_assignments_are_parsed():
    assert normalised_reason("goal in collision, moved 0.40 m back; direct connection") == "direct connection"
    assert normalised_reason("pushed 0.248 of 0.250 m") == "pushed # of # m"
    assert normalised_reason(None) == "ok"
    assert parse_assignments(["arm_rrt=[100,4]", "base_goal=nearest_reachable", "noop_cost=1.0",
                              "arm_collision=false"]) == {"arm_rrt": [100, 4], "base_goal": "nearest_reachable",
                                                          "noop_cost": 1.0, "arm_collision": False}
    with pytest.raises(ValueError, match="KEY=VALUE"):
        parse_assignments(["base_goal"])


def test_the_shipped_policy_s_episode_is_traced_under_another_base_goal_rule(tmp_path, capsys):
    out = tmp_path / "traces.jsonl"
    assert main(["analyse", "episodes", str(SHIPPED), "--episodes", "1", "--seed", "100000",
                 "--set", "episode_steps=4", "--set", "base_goal=nearest_reachable", "--arm", "plan_attempts=1",
                 "--out", str(out), "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    (row,) = rows
    assert row["seed"] == 100_000 and row["steps"] == 4 and len(row["trace"]) == 4 and not row["success"]
    assert all(entry[:2] in ("b:", "a:") for entry in row["trace"]) and row["trace"][0].startswith("b:")
    assert 0.0 <= row["door_angle_deg"] and row["door_opened"] in (0.0, 1.0) and row["cpu_s"] > 0
    assert printed["rows"][0]["trace"] == " ".join(row["trace"])
    summary = summarise_traces(rows)
    assert printed["summary"] == summary and sum(summary["outcomes_per_episode"].values()) == 4
    assert summary["failures"] == {"opened, goal not reached" if row["door_opened"] else "door never opened": 1}
    assert summarise_traces(rows + [dict(row, success=True, trace=["a:ok(R)"])])["repeated_subgoals"] == 0.2
