"""``relmogen analyse reach`` / ``reach-mask`` / ``button-presses``: where arm subgoals can succeed."""

import json

import pytest

from relmogen.analysis.reach import (BANDS, button_presses, by_band, reach_mask_cells, reach_mask_summary,
                                     reach_samples)
from relmogen.cli import main


def test_bands_count_samples_and_plans_by_distance():
    rows = [{"distance": d, "plan_found": ok} for d, ok in ((0.5, True), (0.9, True), (0.95, False), (1.25, False),
                                                             (3.0, False))]
    table = by_band(rows)
    assert len(table) == len(BANDS) + 1
    assert table[0] == {"band_m": "0.0-0.6", "samples": 1, "planned": 1}
    assert table[2] == {"band_m": "0.8-1.0", "samples": 2, "planned": 1}
    assert table[-1] == {"band_m": "all", "samples": 5, "planned": 2, "farthest_planned_m": 0.9}


def test_reach_samples_hand_random_points_to_the_arm(capsys, tmp_path):
    rows = reach_samples("fetch", "TabletopReachM", episodes=1, per_state=3)
    assert len(rows) == 3 and all(r["distance"] > 0 for r in rows)
    assert all(r["plan_found"] == (r["reason"].startswith("pushed") or r["reason"].startswith("push")) for r in rows)
    assert not any(r["plan_found"] for r in rows if r["distance"] > 1.3)  # beyond any arm
    assert main(["analyse", "reach", "--tasks", "TabletopReachM", "--episodes", "1", "--per-state", "2",
                 "--out", str(tmp_path / "reach.json"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["rows"][-1]["samples"] == 2
    assert len(json.loads((tmp_path / "reach.json").read_text())["samples"]) == 2


def test_reach_mask_cells_are_solved_and_looked_up_in_the_measured_map():
    rows = reach_mask_cells("ArrangeKitchenMM", episodes=1, cells_per_state=4, base_moves=0)
    assert 0 < len(rows) <= 4 and all(0 < r["distance"] < 1.3 for r in rows)  # as many as the mask allows
    assert all(isinstance(r["in_map"], bool) and isinstance(r["ik_solved"], bool) for r in rows)
    synthetic = [{"distance": 0.3, "in_map": True, "ik_solved": True}, {"distance": 0.5, "in_map": False, "ik_solved": True},
                 {"distance": 1.1, "in_map": False, "ik_solved": False}, {"distance": 1.15, "in_map": True, "ik_solved": False}]
    summary = reach_mask_summary(synthetic)
    assert summary["ik_solved"] == 0.5 and summary["unsolvable_left_out"] == 0.5 and summary["solvable_left_out"] == 0.5
    assert summary["by_distance"]["1.0-1.2"] == {"cells": 2, "ik_solved": 0.0}


def test_a_straight_push_on_the_button_s_cell_presses_it():
    (row,) = button_presses(episodes=1, radius=0, bins=(0, 6))
    assert row["button_cell"] and row["bins_tried"] == 2
    assert row["bins_pressing"] == [0]  # forward presses, backward does not
