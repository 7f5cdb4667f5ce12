"""``relmogen analyse goal-pixels``: a TabletopReachM relmogen-r policy's first arm pixel against the goal's."""

import json
import math

import numpy as np
import pytest

from relmogen.analysis.goal_pixels import correlation, pixel_statistics
from relmogen.cli import main

GOAL_COLS = np.array([10.3, 20.7, 31.0, 40.2, 52.9])
GOAL_ROWS = np.array([30.1, 33.4, 29.8, 36.0, 31.7])


def test_a_policy_on_the_marker_has_no_error_and_correlation_one():
    stats = pixel_statistics(GOAL_ROWS, GOAL_COLS, GOAL_ROWS, GOAL_COLS, [1, 1, 0, 1, 1])
    assert stats["episodes"] == 5 and stats["first_subgoal_success"] == pytest.approx(0.8)
    for axis, goal in (("column", GOAL_COLS), ("row", GOAL_ROWS)):
        assert stats[axis]["mean_abs_error_px"] == 0.0 and stats[axis]["correlation"] == pytest.approx(1.0)
        assert stats[axis]["goal_std_px"] == pytest.approx(goal.std()) == pytest.approx(stats[axis]["chosen_std_px"])
    shifted = pixel_statistics(GOAL_ROWS + 2, 2 * GOAL_COLS, GOAL_ROWS, GOAL_COLS, np.zeros(5))
    assert shifted["row"]["mean_abs_error_px"] == pytest.approx(2.0)
    assert shifted["column"]["correlation"] == pytest.approx(1.0) and shifted["first_subgoal_success"] == 0.0


def test_a_constant_policy_is_off_by_the_goals_mean_absolute_deviation_with_no_correlation():
    col, row = np.median(GOAL_COLS), np.median(GOAL_ROWS)
    stats = pixel_statistics(np.full(5, row), np.full(5, col), GOAL_ROWS, GOAL_COLS, np.zeros(5))
    assert stats["column"]["mean_abs_error_px"] == pytest.approx(np.abs(GOAL_COLS - col).mean())
    assert stats["row"]["mean_abs_error_px"] == pytest.approx(np.abs(GOAL_ROWS - row).mean())
    assert stats["column"]["correlation"] is None and stats["row"]["correlation"] is None
    assert stats["column"]["chosen_std_px"] == 0.0 and stats["column"]["goal_std_px"] > 0
    assert correlation([1.0], [2.0]) is None and correlation([1, 2, 3], [3, 2, 1]) == pytest.approx(-1.0)
    with pytest.raises(ValueError, match="one length"):
        pixel_statistics([1, 2], [1, 2], [1], [1], [0])


def test_the_topic_runs_a_tiny_tabletop_policy_and_refuses_other_runs(tiny_tabletop_run, tiny_sac_run, capsys):
    assert main(["analyse", "goal-pixels", str(tiny_tabletop_run), "--episodes", "2", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert set(result) == {"image_height", "image_width", "episodes", "column", "row", "first_subgoal_success"}
    assert result["episodes"] == 2 and result["image_height"] > 0 and result["image_width"] > 0
    assert 0.0 <= result["first_subgoal_success"] <= 1.0
    for axis, size in (("column", result["image_width"]), ("row", result["image_height"])):
        values = result[axis]
        assert set(values) == {"mean_abs_error_px", "goal_std_px", "chosen_std_px", "correlation"}
        assert all(values[key] >= 0.0 and math.isfinite(values[key])
                   for key in ("mean_abs_error_px", "goal_std_px", "chosen_std_px"))
        assert values["chosen_std_px"] <= size / 2
        assert values["correlation"] is None or -1.0 - 1e-9 <= values["correlation"] <= 1.0 + 1e-9
    assert main(["analyse", "goal-pixels", str(tiny_tabletop_run), "--episodes", "1"]) == 0
    printed = capsys.readouterr().out
    assert "| axis |" in printed and "first_subgoal_success" in printed
    assert main(["analyse", "goal-pixels", str(tiny_sac_run), "--episodes", "1"]) == 2
    assert "TabletopReachM relmogen-r run" in capsys.readouterr().err
