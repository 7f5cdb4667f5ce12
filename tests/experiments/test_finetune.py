"""Fine-tuning plumbing: ``train --init-from [--init-replay]``, ``env.second_scene`` (half the
training environments in another scene), ``env.robot`` / ``--robot`` (tiny preset runs)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch as th
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.cli import main
from relmogen.experiments.config import read_config, resolve_config
from relmogen.experiments.evaluate import evaluate_path, load_policy
from relmogen.experiments.finetune import INIT_LOG, read_init_from
from relmogen.experiments.checkpoints import latest_checkpoint, latest_replay
from relmogen.experiments.environments import env_kwargs, training_env_kwargs, vec_env_of
from relmogen.experiments.train import check_trainable, train

NO_UPDATES = "algo.learning_starts=100000"  # the new run only collects: its weights stay the loaded ones


def _tiny(task: str = "PointNav", algo: str = "relmogen-r", episodes: int = 1, overrides=()):
    return resolve_config(task, algo, seed=0, preset="tiny", episodes=episodes, overrides=list(overrides))


@pytest.fixture(scope="module")
def source_run(tmp_path_factory) -> Path:
    """A finished tiny SGP-R run on Fetch (2 episodes: it has learned, so its weights are not the
    initial ones, and saved its replay buffer)."""
    return train(_tiny(episodes=2), tmp_path_factory.mktemp("source"), quiet=True)


def _weights(model) -> dict[str, th.Tensor]:
    weights = {f"policy.{k}": v.detach().clone() for k, v in model.policy.state_dict().items()}
    if getattr(model, "log_ent_coef", None) is not None:
        weights["log_ent_coef"] = model.log_ent_coef.detach().clone()
    return weights


def _assert_same_weights(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    assert all(th.equal(a[key], b[key]) for key in a), [key for key in a if not th.equal(a[key], b[key])]


def _replay_size(path: Path, transitions: bool = False) -> int:
    """Rows of n_envs transitions, or with ``transitions`` the transitions themselves."""
    from relmogen.experiments.checkpoints import read_replay_file

    buffer = read_replay_file(path)
    return int(buffer.size() * (buffer.n_envs if transitions else 1))


def test_init_from_copies_the_weights_and_records_the_source(tmp_path, source_run):
    source_model, _, _ = load_policy(source_run)
    fresh = train(_tiny(overrides=[NO_UPDATES]), tmp_path / "fresh", quiet=True)
    run = Path(main_train(tmp_path / "runs", "--init-from", str(source_run), "--set", NO_UPDATES))
    model, config, _ = load_policy(run)
    _assert_same_weights(_weights(model), _weights(source_model))
    assert not all(th.equal(a, b) for a, b in zip(_weights(load_policy(fresh)[0]).values(),
                                                  _weights(source_model).values()))  # not equal by chance
    record = read_init_from(run)
    assert record["run"] == str(source_run.resolve()) and record["algo"] == "relmogen-r" == config.algo
    assert record["checkpoint"] == str(latest_checkpoint(source_run).resolve())
    assert record["checkpoint_episode"] == 2 and record["robot"] == "fetch"
    assert record["replay"] is None and record["replay_transitions"] == 0
    source_state = json.loads((latest_checkpoint(source_run) / "state.json").read_text())
    assert record["initial_episodes"] == 2 and record["initial_cpu_time_s"] == source_state["cpu_time_s"] > 0
    # without --init-replay the new run's replay holds only its own transitions (as many as a run
    # from scratch: before learning_starts both act at random, from the same seed)
    assert _replay_size(latest_replay(run)) == _replay_size(latest_replay(fresh))


def test_init_replay_loads_the_source_replay_buffer(tmp_path, source_run):
    source_rows = _replay_size(latest_replay(source_run))
    source_transitions = _replay_size(latest_replay(source_run), transitions=True)
    run = Path(main_train(tmp_path, "--init-from", str(latest_checkpoint(source_run)), "--init-replay",
                          "--set", NO_UPDATES))
    record = read_init_from(run)
    assert record["replay"] == str(latest_replay(source_run).resolve())
    assert record["replay_transitions"] == source_transitions > 0
    own = _replay_size(latest_replay(train(_tiny(overrides=[NO_UPDATES]), tmp_path / "fresh", quiet=True)))
    capacity = read_config(run / "config.yaml").algo_params.buffer_size
    assert _replay_size(latest_replay(run)) == min(source_rows + own, capacity)
    _assert_same_weights(_weights(load_policy(run)[0]), _weights(load_policy(source_run)[0]))


def test_init_from_fetch_to_movo_keeps_the_weights(tmp_path, source_run):
    """SGP-R from Fetch to Movo: the same observation and action spaces, the paper's new-robot
    fine-tuning; the new run trains on Movo."""
    run = Path(main_train(tmp_path, "--init-from", str(source_run), "--robot", "movo", "--set", NO_UPDATES))
    assert read_config(run / "config.yaml").env.robot == "movo"
    assert read_init_from(run)["robot"] == "fetch"
    _assert_same_weights(_weights(load_policy(run)[0]), _weights(load_policy(source_run)[0]))
    result = evaluate_path(run, episodes=1, quiet=True)
    assert result["robot"] == "movo" and list((run / "eval").glob("eval_office_A_movo_*.json"))


def test_init_from_refuses_other_spaces_or_algorithms(tmp_path, source_run, capsys):
    out = tmp_path / "runs"
    assert main(["train", "--task", "TabletopReachM", "--algo", "relmogen-r", "--preset", "tiny", "--episodes", "1",
                 "--out", str(out), "--quiet", "--init-from", str(source_run)]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "observation space differs" in error and "task_obs" in error
    assert not out.exists() or not list(out.iterdir())  # nothing left behind
    assert main(["train", "--task", "PointNav", "--algo", "sac", "--preset", "tiny", "--episodes", "1",
                 "--out", str(out), "--quiet", "--init-from", str(source_run)]) == 2
    assert "trained relmogen-r, this one trains sac" in capsys.readouterr().err
    assert main(["train", "--task", "PointNav", "--algo", "relmogen-r", "--preset", "tiny", "--out", str(out),
                 "--init-replay"]) == 2
    assert "--init-from" in capsys.readouterr().err


def test_second_scene_puts_half_the_environments_in_it():
    config = _tiny(overrides=["env.n_envs=4", "env.second_scene=office_B"])
    assert [kwargs["scene"] for kwargs in training_env_kwargs(config)] == [None, None, "office_B", "office_B"]
    config = _tiny(overrides=["env.n_envs=4", "env.second_scene=office_B", "env.second_scene_fraction=0.25"])
    assert [kwargs["scene"] for kwargs in training_env_kwargs(config)] == [None, None, None, "office_B"]
    config = _tiny(overrides=["env.n_envs=2", "env.scene=office_A", "env.second_scene=office_B"])
    envs = vec_env_of(training_env_kwargs(config), seed=0, vec_env_cls=DummyVecEnv)
    try:
        assert [env.unwrapped.scene.name for env in envs.envs] == ["office_A", "office_B"]
    finally:
        envs.close()
    # evaluation (env_kwargs) keeps the run's own scene; eval --scene chooses another
    assert env_kwargs(config, arm_collision=True)["scene"] == "office_A"


def test_second_scene_and_robot_are_validated():
    with pytest.raises(ValueError, match="rounds to|leaving one scene without any"):
        _tiny(overrides=["env.second_scene=office_B"])  # n_envs 1: no half to swap
    assert _tiny(overrides=["env.second_scene=office_B", "env.second_scene_fraction=1"]).env.second_scene_envs == 1
    with pytest.raises(ValueError, match="office scene .env.second_scene."):
        check_trainable(_tiny(overrides=["env.n_envs=2", "env.second_scene=house_B"]))
    with pytest.raises(ValueError, match="unknown robot 'rosie'.*fetch, movo"):
        _tiny(overrides=["env.robot=rosie"])


def test_robot_movo_trains_a_tiny_run(tmp_path):
    run = Path(main_train(tmp_path, "--task", "PointNav", "--algo", "relmogen-r", "--robot", "movo"))
    assert read_config(run / "config.yaml").env.robot == "movo"
    assert (run / "done.json").is_file() and latest_checkpoint(run) is not None
    assert not (run / INIT_LOG).exists()


def main_train(out: Path, *args: str) -> str:
    """``relmogen train`` on the tiny preset for one episode; the printed run directory."""
    import contextlib
    import io

    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        code = main(["train", "--preset", "tiny", "--episodes", "1", "--out", str(out), "--quiet", *args])
    assert code == 0
    return buffer.getvalue().strip().splitlines()[-1]
