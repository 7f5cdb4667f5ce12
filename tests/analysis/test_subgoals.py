"""``relmogen analyse door-distance``: where the base stood when the arm pushed."""

import json
from pathlib import Path

import pytest

from relmogen.analysis.subgoals import distances_at_arm_subgoals, door_distance_row
from relmogen.cli import main

REPO = Path(__file__).resolve().parents[2]


def test_each_arm_subgoal_takes_the_last_base_subgoal_before_it_in_its_episode(tmp_path):
    figure = {"robot": "fetch", "checkpoint": "best", "episodes": 2, "success_rate": 0.5, "arm_plan_rate": 1.0,
              "base": [{"episode": 0, "step": 0, "door_distance": 1.0}, {"episode": 0, "step": 2, "door_distance": 0.4},
                       {"episode": 1, "step": 1, "door_distance": 0.3}],
              "arm": [{"episode": 0, "step": 1}, {"episode": 0, "step": 3}, {"episode": 0, "step": 4},
                      {"episode": 1, "step": 0}, {"episode": 1, "step": 2}]}
    assert distances_at_arm_subgoals(figure) == [1.0, 0.4, 0.4, 0.3]  # episode 1's first arm: no base before
    path = tmp_path / "subgoals.json"
    path.write_text(json.dumps(figure))
    row = door_distance_row(path)
    assert row["arm_subgoals"] == 4 and row["mean_door_distance"] == pytest.approx(0.525)
    assert row["quartiles"][1] == pytest.approx(0.4)
    assert row["median_gap_to_base_edge"] == pytest.approx(0.4 - 0.279)  # Fetch's base radius


def test_the_committed_movo_figures_give_readme_s_gaps(capsys):
    folder = REPO / "results" / "finetune-robot"
    figures = [folder / f"subgoals_{name}.json" for name in ("fetch", "movo_zero_shot", "movo_finetuned")]
    assert main(["analyse", "door-distance", *map(str, figures), "--json"]) == 0
    gaps = [row["median_gap_to_base_edge"] for row in json.loads(capsys.readouterr().out)["rows"]]
    assert [round(g, 2) for g in gaps] == [0.04, 0.04, 0.11]  # README: 0.11 m after fine-tuning, 0.04 m Fetch
