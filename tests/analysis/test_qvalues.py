"""``relmogen analyse qvalues`` / ``oracle-cells``: a relmogen-d checkpoint's Q maps."""

import json
from types import SimpleNamespace

import numpy as np
import pytest

from relmogen.analysis.qvalues import (cap_row, greedy_summary, greedy_values, oracle_cell_table, oracle_states,
                                       oracle_states_summary, state_row)
from relmogen.cli import main
from relmogen.envs.subgoal_controls import PUSH_BINS, YAW_BINS


def fake_state(q=2):
    """Q maps whose value is the action index; the base cell (1, 1) and the arm cell (0, 1) masked."""
    maps = np.arange((YAW_BINS + PUSH_BINS) * q * q, dtype=float).reshape(YAW_BINS + PUSH_BINS, q, q)
    masks = np.ones((2, q, q), bool)
    masks[0, 1, 1] = masks[1, 0, 1] = False
    return SimpleNamespace(q_maps=maps, masks=masks, choice=("arm", 11, 1, 1))


def test_state_and_cap_rows_rank_among_the_allowed_actions_only():
    state = fake_state()
    n = (YAW_BINS + PUSH_BINS) * 4
    allowed = n - YAW_BINS - PUSH_BINS  # one cell masked per part
    row = state_row(state, oracle_index=0)
    assert row["allowed_actions"] == allowed and row["oracle_percentile"] == 0.0 and row["best_q"] == n - 1
    assert state_row(state, oracle_index=3)["oracle_allowed"] is False  # base cell (1, 1)
    cap = np.array([[False, True], [True, False]])  # cell (0, 1) is masked: only (1, 0) counts
    row = cap_row(state, cap)
    assert row["cap_actions"] == PUSH_BINS and row["best_cap_q"] == n - 2  # the last arm map's cell (1, 0)
    assert row["cap_percentile"] == pytest.approx(100.0 * (allowed - 2) / allowed)
    assert row["softmax_cap_mass_T0.03"] == pytest.approx(1 / (1 + np.exp(1 / 0.03)), rel=1e-3)


def test_oracle_states_and_greedy_values_of_a_tiny_checkpoint(tiny_dqn_run, capsys):
    rows = oracle_states(tiny_dqn_run, states=2, button_only=True)
    assert len(rows) == 2 and rows[0]["episode"] != rows[1]["episode"]  # one state per episode
    for row in rows:
        assert row["oracle_allowed"] and 0.0 <= row["oracle_percentile"] <= 100.0 and row["cap_actions"] > 0
        assert row["best_q"] >= row["p90_q"] >= row["median_q"] and row["greedy"][0] in ("base", "arm")
    summary = oracle_states_summary(rows)
    assert summary["states"] == 2 and summary["mean_oracle_percentile"] == pytest.approx(
        np.mean([r["oracle_percentile"] for r in rows]), abs=1e-3)
    episodes = greedy_values(tiny_dqn_run, episodes=1)
    (episode,) = episodes
    assert episode["steps"] == 10 == len(episode["per_step"]) and episode["mean_base_q"] is not None
    assert greedy_summary(episodes)["steps"] == 10
    assert main(["analyse", "qvalues", "greedy", str(tiny_dqn_run), "--episodes", "1", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed["rows"][0]["return"] == episode["return"]  # greedy: the same episode again


def test_the_oracle_cell_table_summarises_viz_qmap_over_seeds(tmp_path):
    for seed, percentile in enumerate((60.0, 70.0, 80.0)):
        folder = tmp_path / "3.5h" / f"ButtonDoorNav__relmogen-d__{seed}__x"
        folder.mkdir(parents=True)
        folder.joinpath("oracle_cells.json").write_text(json.dumps(
            {"pushes": 16, "mean_percentile": percentile, "mean_area_percentile": None, "greedy_arm": 2,
             "greedy_is_oracle_cell": seed}))
    (row,) = oracle_cell_table([tmp_path / "3.5h"])
    assert row["stage"] == "3.5h" and row["task"] == "ButtonDoorNav" and row["seeds"] == 3
    assert row["percentile"] == [70.0, 8.2, 80.0] and row["area_percentile"] is None
    assert row["greedy_arm"] == 6 and row["greedy_is_oracle_cell"] == 3 and row["states"] == 48
    with pytest.raises(ValueError, match="no \\*/oracle_cells.json"):
        oracle_cell_table([tmp_path])
