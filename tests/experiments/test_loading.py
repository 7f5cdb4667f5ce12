"""``relmogen.load``: a policy carries its run's settings, and in a plain Gymnasium loop it scores
what ``relmogen eval`` scores on the same seeds."""

import shutil
import subprocess
import sys

import pytest

import relmogen
import relmogen.experiments.evaluate as evaluate
from relmogen.experiments.shipped import shipped_policy_dir
from relmogen.experiments.config import resolve_config
from relmogen.experiments.checkpoints import latest_checkpoint
from relmogen.experiments.train import train

SHIPPED = shipped_policy_dir("PushDoorNav-relmogen-r")
RUN_SETTINGS = {"noop_cost": 0.5, "base_goal": "nearest_reachable", "push_frame": "surface"}  # not the defaults


def gym_loop(trained, episodes: int, seed: int) -> list[tuple[bool, float]]:
    """(success, return) of each episode, as a user would write it: ``make_env``, ``policy``, steps."""
    env = trained.make_env()
    act = trained.policy(env)
    outcomes = []
    try:
        for episode in range(episodes):
            obs, info = env.reset(seed=seed + episode)
            done, episode_return = False, 0.0
            while not done:
                obs, reward, terminated, truncated, info = env.step(act(obs))
                episode_return += reward
                done = terminated or truncated
            outcomes.append((bool(info["is_success"]), episode_return))
    finally:
        env.close()
    return outcomes


def eval_episodes(monkeypatch, path, episodes: int, seed: int) -> tuple[list[tuple[bool, float]], dict]:
    """(success, return) of each episode of ``relmogen eval``'s evaluation of ``path``, and its result."""
    records, run_episodes = [], evaluate.run_episodes

    def recording(*args, **kwargs):
        records.extend(run_episodes(*args, **kwargs))
        return records

    monkeypatch.setattr(evaluate, "run_episodes", recording)
    result = evaluate.evaluate_path(path, episodes, seed, quiet=True, save=False)
    return [(bool(record.metrics["success"]), record.episode_return) for record in records], result


@pytest.fixture(scope="module")
def shipped():
    return relmogen.load(SHIPPED)


def test_the_shipped_policy_scores_in_a_gym_loop_what_relmogen_eval_scores(shipped, monkeypatch):
    episodes, seed = 2, 100_000
    in_gym_loop = gym_loop(shipped, episodes, seed)
    in_eval, result = eval_episodes(monkeypatch, SHIPPED, episodes, seed)
    assert in_gym_loop == in_eval
    assert result["success_rate"] == sum(success for success, _ in in_gym_loop) / episodes
    assert result["checkpoint"] == "best_0000400" and not (SHIPPED / "eval").exists()  # the package stays clean


def test_the_shipped_policy_carries_its_settings_into_make_env(shipped):
    assert (shipped.env_id, shipped.checkpoint_name, shipped.checkpoint_episode) == ("relmogen/PushDoorNav-v0",
                                                                                     "best_0000400", 400)
    assert {key: shipped.env_kwargs[key] for key in ("base_goal", "noop_cost", "subgoal_feedback", "image_size",
                                                     "arm_collision")} == {
        "base_goal": "nearest_free", "noop_cost": 1.0, "subgoal_feedback": True, "image_size": 64,
        "arm_collision": True}
    env = shipped.make_env(render_mode="rgb_array")  # an override beside the run's settings
    try:
        control = env.unwrapped.control
        assert (control.noop_cost, control.mg.config.base_goal) == (1.0, "nearest_free")
        obs, _ = env.reset(seed=0)
        assert obs["rgb"].shape[:2] == (64, 64) and env.render().ndim == 3
    finally:
        env.close()
    with pytest.raises(ValueError, match="exported actor"):
        relmogen.load(SHIPPED, checkpoint="best")


@pytest.fixture(scope="module")
def subgoal_d_run(tmp_path_factory):
    overrides = [f"env.{key}={value}" for key, value in RUN_SETTINGS.items()]
    config = resolve_config("PointNav", "relmogen-d", seed=0, preset="tiny", episodes=1, overrides=overrides)
    return train(config, tmp_path_factory.mktemp("runs"), quiet=True)


def test_a_run_and_its_checkpoints_carry_the_run_settings(subgoal_d_run, tmp_path):
    trained = relmogen.load(subgoal_d_run)
    assert {key: trained.env_kwargs[key] for key in RUN_SETTINGS} == RUN_SETTINGS
    assert trained.env_kwargs["control"] == "subgoal-d" and trained.env_kwargs["arm_collision"] is True
    checkpoint = latest_checkpoint(subgoal_d_run)
    assert (checkpoint / "config.yaml").read_text() == (subgoal_d_run / "config.yaml").read_text()
    copied = shutil.copytree(checkpoint, tmp_path / "moved" / checkpoint.name)  # out of its run
    moved = relmogen.load(copied)
    assert moved.env_kwargs == trained.env_kwargs and moved.checkpoint_episode == 1


@pytest.mark.parametrize("algo", ["relmogen-d", "hrl4in"])
def test_a_trained_run_scores_in_a_gym_loop_what_relmogen_eval_scores(algo, subgoal_d_run, tmp_path, monkeypatch):
    run = subgoal_d_run if algo == "relmogen-d" else train(  # SGP-D: its masks; HRL4IN: its held subgoals
        resolve_config("PointNav", algo, seed=0, preset="tiny", episodes=1), tmp_path, quiet=True)
    in_gym_loop = gym_loop(relmogen.load(run), episodes=2, seed=0)
    in_eval, _ = eval_episodes(monkeypatch, run, episodes=2, seed=0)
    assert in_gym_loop == in_eval


def test_importing_relmogen_does_not_load_the_policy_machinery():
    loaded = subprocess.run([sys.executable, "-c", "import sys, relmogen; print(sorted(m for m in sys.modules if "
                             "m.startswith(('stable_baselines3', 'torch', 'relmogen.experiments'))))"],
                            capture_output=True, text=True, check=True).stdout
    assert loaded.strip() == "[]"
