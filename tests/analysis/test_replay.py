"""``relmogen analyse replay`` / ``offline-updates``: what a relmogen-d replay holds, more updates on it."""

import json
from types import SimpleNamespace

import numpy as np
import pytest
import torch as th

from relmogen.agents.dqn import RelmogenDQN
from relmogen.analysis.replay import action_rewards, button_pushes, load_replay, offline_updates
from relmogen.cli import main
from relmogen.envs.subgoal_controls import YAW_BINS, encode_indices
from relmogen.experiments.checkpoints import latest_checkpoint

Q = 4


def fake_buffer():
    """Six transitions of one environment in 16 x 16 images (4 x 4 cells): a red cap in cell (1, 2)
    of the first four frames; pushes on it, next to it, and base moves."""
    rgb = np.zeros((8, 1, 3, 16, 16), np.uint8)
    rgb[:4, 0, 0, 4:8, 8:12] = 200  # cell (1, 2), channels first as the replay stores them
    actions = [encode_indices(True, 3, 1, 2, Q), encode_indices(True, 3, 1, 2, Q), encode_indices(True, 0, 3, 3, Q),
               encode_indices(False, 5, 0, 0, Q), encode_indices(True, 3, 1, 2, Q), encode_indices(True, 3, 1, 2, Q)]
    rewards = [5.0, 0.0, 10.0, -0.5, 0.0, 0.0]
    return SimpleNamespace(observations={"rgb": rgb}, actions=np.array(actions + [0, 0]).reshape(8, 1, 1),
                           rewards=np.array(rewards + [0, 0], np.float32).reshape(8, 1), pos=6, full=False,
                           buffer_size=8)


def test_button_pushes_are_counted_by_the_cap_in_their_own_frame():
    counts = button_pushes(fake_buffer(), Q)
    assert counts == {"transitions": 6, "arm_pushes": 5, "cap_in_view": 3, "on_the_cap": 2,
                      "on_the_cap_rewarded": 1, "elsewhere_rewarded": 1}  # the last two: the cap out of view


def test_rewards_per_action_and_the_most_frequent_actions():
    result = action_rewards(fake_buffer(), Q, [(3, 1, 2), (0, 0, 0)], top=2)
    assert result["transitions"] == 6 and result["arm_share"] == pytest.approx(5 / 6, abs=1e-3)
    assert result["mean_reward"] == pytest.approx(14.5 / 6, abs=1e-4) and result["base_mean_reward"] == -0.5
    assert result["given"] == [{"action": ["arm", 3, 1, 2], "times": 4, "mean_reward": 1.25},
                               {"action": ["arm", 0, 0, 0], "times": 0, "mean_reward": None}]
    assert result["most_frequent"][0] == {"action": ["arm", 3, 1, 2], "times": 4, "mean_reward": 1.25,
                                          "rewards_above_0.5": 0.25}
    assert YAW_BINS * Q * Q == encode_indices(True, 0, 0, 0, Q)


def test_a_tiny_run_s_replay_and_offline_updates_on_it(tiny_dqn_run, tmp_path, capsys):
    buffer, q = load_replay(tiny_dqn_run)
    assert q == 16
    assert main(["analyse", "replay", "pushes", str(tiny_dqn_run), "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)["rows"]
    assert row == {"run": tiny_dqn_run.name, **button_pushes(buffer, q)} and row["transitions"] == 20
    before = RelmogenDQN.load(latest_checkpoint(tiny_dqn_run) / "model.zip", device="cpu")
    out = tmp_path / "offline"
    summary = offline_updates(tiny_dqn_run, out, updates=3)
    assert summary["updates"] == 3 and summary["stored_transitions"] == 20 and summary["target_copy_every"] == 50
    assert np.isfinite(summary["loss_first_1000"]) and json.loads((out / "offline_updates.json").read_text()) == summary
    after = RelmogenDQN.load(latest_checkpoint(out) / "model.zip", device="cpu")
    changed = [not th.equal(a, b) for a, b in zip(before.q_net.parameters(), after.q_net.parameters())]
    assert any(changed) and (out / "config.yaml").is_file() and (out / "episodes.csv").is_file()
    with pytest.raises(ValueError, match="exists"):
        offline_updates(tiny_dqn_run, out, updates=1)
    with pytest.raises(ValueError, match="from-scratch"):
        offline_updates(tiny_dqn_run, tmp_path / "other", updates=1, settings=["algo.qmap_skip=true"])
