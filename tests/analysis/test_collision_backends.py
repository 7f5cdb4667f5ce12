"""relmogen analyse collision-backends: both backends on the same configurations, per task."""

from __future__ import annotations

import json

from relmogen.cli import main


def test_collision_backends_compares_both_backends_on_the_same_configurations(capsys):
    assert main(["analyse", "collision-backends", "--tasks", "ArrangeKitchenMM", "--configurations", "60",
                 "--seeds", "0", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    (row,) = result["rows"]
    assert row["configurations"] == 60 and row["task"] == "ArrangeKitchenMM"
    assert row["pybullet_only"] + row["coal_only"] == round((1 - row["agreement"]) * 60)
    assert row["agreement"] >= 0.95 and row["coal_us_per_query"] > 0 and row["pybullet_us_per_query"] > 0
    assert 0 < row["pybullet_collision_rate"] < 1
    assert result["summary"]["agreement_min"] == row["agreement"]
