"""HRL4IN (``--algo hrl4in``): a tiny run trains, saves, resumes and evaluates; the embodiment
mask zeroes the masked joint velocities; the intrinsic reward is the module doc's."""

import json
import zipfile

import numpy as np
import pytest

from relmogen.agents.hrl4in import (EMBODIMENT_MASKS, HRL4IN, HRL4INSettings, Subgoal, intrinsic_reward,
                                    masked_command)
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.config import resolve_config
from relmogen.experiments.evaluate import evaluate_path, load_checkpoint
from relmogen.experiments.checkpoints import latest_checkpoint, latest_replay, load_replay
from relmogen.experiments.environments import env_kwargs
from relmogen.experiments.resume import resume
from relmogen.experiments.train import train

EVAL_KEYS = {"task", "algo", "training_seed", "eval_seed", "scene", "policy", "episodes", "success_rate", "spl",
             "closed_5", "closed_10", "mean_return", "mean_steps", "checkpoint", "checkpoint_episode"}


pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    config = resolve_config("PointNav", "hrl4in", preset="tiny", episodes=2)
    return train(config, out=tmp_path_factory.mktemp("runs"), quiet=True)


def test_a_tiny_run_trains_both_levels_and_saves_them(tiny_run):
    checkpoint = latest_checkpoint(tiny_run)
    with zipfile.ZipFile(checkpoint / "model.zip") as archive:
        assert {"high.zip", "low.zip", "hrl4in.json"} <= set(archive.namelist())
        state = json.loads(archive.read("hrl4in.json"))
    assert state["num_timesteps"] == 20 and state["high_transitions"] >= 2 * 10 // 3
    model, config = load_checkpoint(checkpoint, tiny_run, device="cpu")
    assert isinstance(model, HRL4IN) and model.settings.k == config.algo_params.hrl4in_k == 3
    load_replay(model, latest_replay(tiny_run))
    assert model.low.replay_buffer.size() == 20  # one low-level transition per environment step
    assert model.high.replay_buffer.size() == state["high_transitions"]  # one per subgoal
    assert model.low._n_updates > 0 and model.high._n_updates > 0


def test_resume_continues_both_levels_and_eval_writes_the_usual_json(tiny_run):
    before, _ = load_checkpoint(latest_checkpoint(tiny_run), tiny_run, device="cpu")
    resume(tiny_run, quiet=True, episodes=3)
    after, _ = load_checkpoint(latest_checkpoint(tiny_run), tiny_run, device="cpu")
    assert after.num_timesteps == 30 and after.high_transitions > before.high_transitions
    assert after.low._n_updates > before.low._n_updates and after.high._n_updates > before.high._n_updates
    done = json.loads((tiny_run / "done.json").read_text())
    assert done["gradient_updates"] == after._n_updates == after.low._n_updates + after.high._n_updates
    rows = (tiny_run / "episodes.csv").read_text().splitlines()
    assert [row.split(",")[0] for row in rows[1:]] == ["1", "2", "3"]
    result = evaluate_path(tiny_run, episodes=1, seed=7, device="cpu", quiet=True)
    assert EVAL_KEYS <= set(result) and result["algo"] == "hrl4in" and result["checkpoint_episode"] == 3
    assert result["mean_steps"] <= 10
    saved = list((tiny_run / "eval").glob("*.json"))
    assert len(saved) == 1 and json.loads(saved[0].read_text())["eval_seed"] == 7


@pytest.mark.parametrize("embodiment", ["base", "arm", "both"])
def test_the_embodiment_mask_zeroes_the_masked_joint_velocities(embodiment):
    _, action_mask = EMBODIMENT_MASKS[embodiment]
    command = masked_command(np.full(10, 0.7), action_mask)
    moving = {"base": [0, 1], "arm": list(range(2, 10)), "both": list(range(10))}[embodiment]
    assert np.flatnonzero(command).tolist() == moving
    np.testing.assert_allclose(command[moving], 0.7, rtol=1e-6)


def test_the_policy_commands_only_the_chosen_embodiment(tiny_run):
    model, config = load_checkpoint(latest_checkpoint(tiny_run), tiny_run, device="cpu")
    env = RelmogenEnv(**env_kwargs(config, arm_collision=True))
    try:
        obs, _ = env.reset(seed=3)
        for embodiment in ("base", "arm", "both"):
            model.settings = HRL4INSettings(k=3, embodiments=(embodiment,))  # the selector's only choice
            policy = model.evaluation_policy(env, deterministic=False)
            policy.reset()
            for _ in range(2):
                command = policy(obs)
                assert policy.subgoal.embodiment == embodiment
                np.testing.assert_array_equal(command[EMBODIMENT_MASKS[embodiment][1] == 0], 0.0)
                obs, *_ = env.step(command)
    finally:
        env.close()


def test_the_high_level_action_decodes_to_a_world_target_and_the_largest_score_picks_the_embodiment():
    settings = HRL4INSettings(base_range=2.0, ee_range=0.5)
    state = np.array([1.0, 2.0, np.pi / 2, 1.2, 2.1, 0.9])  # base (x, y, yaw), end effector (x, y, z)
    action = np.array([0.5, 0.0, 1.0, 0.0, -1.0, -0.2, 0.1, 0.9])  # scores: base, arm, both
    subgoal = Subgoal.from_action(action, state, settings)
    assert subgoal.embodiment == "both"
    # 1 m ahead of a robot facing +y is +y in the world; the end effector 0.5 m ahead and 0.5 m down
    np.testing.assert_allclose(subgoal.target, [1.0, 3.0, 1.2, 2.6, 0.4], atol=1e-9)
    np.testing.assert_allclose(subgoal.remaining(state), [1.0, 0.0, 0.5, 0.0, -0.5], atol=1e-6)
    arm = Subgoal.from_action(np.r_[action[:5], 0.0, 1.0, 0.0], state, settings)
    assert arm.embodiment == "arm"
    np.testing.assert_allclose(arm.remaining(state), [0.0, 0.0, 0.5, 0.0, -0.5], atol=1e-6)


def test_the_intrinsic_reward_is_the_documented_sum():
    settings = HRL4INSettings(progress_scale=30.0, distance_weight=0.5, success_bonus=2.0, mask_penalty=0.1,
                              extrinsic_weight=0.25, tolerance=0.1)
    start = np.array([0.0, 0.0, 0.0, 0.3, 0.0, 0.8])
    subgoal = Subgoal.from_action(np.array([0.5, 0.0, 0.0, 0.0, 0.0, 1.0, -1.0, -1.0]), start,
                                  HRL4INSettings(base_range=1.0))
    assert subgoal.embodiment == "base"  # target: base at (0.5, 0); the end effector is masked out
    action = np.array([0.2, 0.4, 0.5, 0, 0, 0, 0, 0, 0, -1.0])  # torso 0.5 and last arm joint -1 are masked
    penalty = 0.5 ** 2 + 1.0 ** 2
    after = np.array([0.2, 0.0, 0.0, 0.5, 0.0, 0.5])  # 0.2 m closer; the end effector's move is not counted
    reward, achieved, terms = intrinsic_reward(subgoal, start, after, action, extrinsic=-1.0, settings=settings)
    assert not achieved
    expected = 30.0 * (0.5 - 0.3) - 0.5 * 0.3 + 0.0 - 0.1 * penalty + 0.25 * -1.0
    assert reward == pytest.approx(expected) and sum(terms.values()) == pytest.approx(expected)
    assert terms["mask"] == pytest.approx(-0.1 * penalty)
    close = np.array([0.45, 0.05, 0.0, 0.0, 0.0, 0.0])  # every masked-in component within 0.1 m
    reward, achieved, terms = intrinsic_reward(subgoal, start, close, np.zeros(10), extrinsic=0.0, settings=settings)
    distance = float(np.hypot(0.05, 0.05))
    assert achieved and terms["success"] == 2.0
    assert reward == pytest.approx(30.0 * (0.5 - distance) - 0.5 * distance + 2.0)


@pytest.mark.parametrize("preset", ["tiny", "cpu", "paper"])
def test_every_preset_has_a_valid_hrl4in_block(preset):
    from relmogen.agents.hrl4in import settings_from_params
    from relmogen.experiments.config import load_preset

    assert "hrl4in" in load_preset(preset)["algos"]
    config = resolve_config("PushDoorNav", "hrl4in", preset=preset)
    settings = settings_from_params(config.algo_params)
    assert config.control == "joint" and settings.high_action_dim == 5 + len(settings.embodiments)
