"""``relmogen analyse oracle-table`` and ``random-sgpd``: the floors and ceilings."""

import json

import numpy as np
import pytest

from relmogen.agents.dqn import YAW_BINS
from relmogen.analysis.oracles import oracle_rows, part_coin, random_sgpd
from relmogen.cli import main


def test_the_table_holds_the_oracle_jsons_of_a_folder_only(tmp_path, capsys):
    (tmp_path / "B_oracle.json").write_text(json.dumps({"task": "B", "policy": "oracle", "base_planner": "lazy_prm",
                                                        "episodes": 50, "success_rate": 0.7, "mean_steps": 9.5}))
    (tmp_path / "A_random.json").write_text(json.dumps({"task": "A", "policy": "random", "base_planner": "rrt_connect",
                                                        "episodes": 50, "success_rate": 0.0}))
    (tmp_path / "runs.json").write_text(json.dumps({"settings": []}))  # not an oracle result
    rows = oracle_rows(tmp_path)
    assert [(r["task"], r["policy"], r["planners"]) for r in rows] == [("A", "random", "rrt_connect"),
                                                                      ("B", "oracle", "lazy_prm")]
    assert rows[1]["success_rate"] == 0.7 and rows[1]["spl"] is None
    assert main(["analyse", "oracle-table", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("| task | policy | planners |") and "| B | oracle | lazy_prm | 50 | 0.700 |" in lines[3]


def test_part_coin_picks_a_part_first_and_falls_back_to_the_other():
    q = 2
    allowed = np.zeros((200, (YAW_BINS + 12) * q * q), bool)
    allowed[:, 3] = allowed[:, YAW_BINS * q * q + 5] = True  # one base and one arm action
    np.random.seed(0)
    picks = part_coin(allowed, q)
    assert set(picks) == {3, YAW_BINS * q * q + 5} and 0.35 < np.mean(picks == 3) < 0.65
    only_base = allowed.copy()
    only_base[:, YAW_BINS * q * q:] = False
    assert set(part_coin(only_base, q)) == {3}


def test_random_sgpd_runs_the_uniform_policy_through_the_task_metrics():
    result = random_sgpd("ButtonDoorNav", episodes=1, image_size=32, episode_steps=3)
    assert result["episodes"] == 1 and result["mean_steps"] == 3 and result["qmap_size"] == 8
    assert result["success_rate"] == 0.0 and 0.0 <= result["base_fraction"] <= 1.0 and "button_pressed" in result
    with pytest.raises(ValueError, match="sampler"):
        random_sgpd("ButtonDoorNav", sampler="greedy")
