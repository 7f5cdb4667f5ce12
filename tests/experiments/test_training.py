"""End to end: train a few hundred steps on the tiny preset, checkpoint, resume, evaluate."""

import csv
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import gymnasium as gym
import imageio.v2 as imageio
import numpy as np
import psutil
import pytest
import torch as th
import yaml
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from relmogen.agents.dqn import RelmogenDQN
from relmogen.experiments.shipped import export_actor, open_shipped
from relmogen.cli import main
from relmogen.experiments.config import load_preset, read_config, resolve_config
from relmogen.experiments.env_workers import WORKER_ERRORS, EnvWorkerError, GuardedSubprocVecEnv, last_logged_error
from relmogen.experiments.evaluate import evaluate_path, load_policy, resolve_checkpoint
from relmogen.experiments.report import final_evaluation
from relmogen.experiments.budgets import scheduled_gradient_updates, stop_reason
from relmogen.experiments.checkpoints import best_checkpoint, evaluation_rank, latest_checkpoint, latest_replay, read_replay_file
from relmogen.experiments.environments import env_kwargs, make_training_env, worker_env
from relmogen.experiments.monitor import EPISODE_FIELDS, TrainingMonitor
from relmogen.experiments.resume import read_resume_log, resume, truncate_episode_log
from relmogen.experiments.train import train
from relmogen.visualisation.qmap import q_map_figures_for_checkpoint
from relmogen.experiments.video import VIDEO_SIZE


def episodes_in(run_dir: Path) -> list[int]:
    with open(run_dir / "episodes.csv", newline="") as handle:
        return [int(row["episode"]) for row in csv.DictReader(handle)]


def assert_gradient_updates_are_counted_across_sessions(run_dir: Path, config, first_session: dict) -> None:
    """done.json counts every gradient step of the run, the first session's and the resumed one's;
    the update schedule, which reports derive for runs older than the count, is right within the
    rollout that the stop cut short."""
    model, _, _ = load_policy(run_dir)
    done = json.loads((run_dir / "done.json").read_text())
    assert 0 < first_session["gradient_updates"] < done["gradient_updates"] == model._n_updates
    scheduled = scheduled_gradient_updates(config, first_session["timesteps"])
    assert 0 <= scheduled - first_session["gradient_updates"] <= config.algo_params.gradient_steps


@pytest.mark.parametrize("algo,episodes", [("sac", 5), ("oac", 5), ("relmogen-r", 3), ("relmogen-d", 3)])
def test_train_checkpoint_resume_evaluate(tmp_path, algo, episodes):
    config = resolve_config("PointNav", algo, seed=0, preset="tiny", episodes=episodes)
    run_dir = train(config, tmp_path, quiet=True)
    assert (run_dir / "config.yaml").is_file() and list((run_dir / "tb").iterdir())
    tags = EventAccumulator(str(run_dir / "tb")).Reload().Tags()["scalars"]
    assert {"charts/episodic_return", "charts/success_rate", "charts/SPS", "reward_terms/geodesic"} <= set(tags)
    assert len(EventAccumulator(str(run_dir / "tb")).Reload().Scalars("reward_terms/geodesic")) == episodes
    steps = [event.value for event in EventAccumulator(str(run_dir / "tb")).Reload().Scalars("charts/global_step")]
    assert steps == [float(row["timesteps"]) for row in csv.DictReader(open(run_dir / "episodes.csv", newline=""))]
    assert ("charts/epsilon" in tags) == (algo == "relmogen-d")
    assert episodes_in(run_dir) == list(range(1, episodes + 1))
    shares = [row["base_fraction"] for row in csv.DictReader(open(run_dir / "episodes.csv", newline=""))]
    if algo.startswith("relmogen"):  # subgoal controls log the base share of each episode's subgoals
        assert all(0.0 <= float(share) <= 1.0 for share in shares)
    else:
        assert set(shares) == {""}
    assert {row["closed_10"] for row in csv.DictReader(open(run_dir / "episodes.csv", newline=""))} == {""}
    state = json.loads((latest_checkpoint(run_dir) / "state.json").read_text())
    assert state["episodes"] == episodes and state["timesteps"] >= episodes
    assert (latest_replay(run_dir)).is_file()
    # resume with a larger budget: continues from the checkpoint, keeps the replay buffer, and
    # uses the config's torch threads (two OpenMP threads on a busy 2-core machine thrash)
    th.set_num_threads(2)
    resume(run_dir, quiet=True, episodes=episodes + 2)
    assert th.get_num_threads() == config.run.torch_threads == 1
    # resuming a run whose budget is spent finishes at once, from the same checkpoint
    before = latest_checkpoint(run_dir)
    resume(run_dir, quiet=True)
    assert latest_checkpoint(run_dir) == before and (run_dir / "done.json").is_file()
    assert episodes_in(run_dir) == list(range(1, episodes + 3))
    assert_gradient_updates_are_counted_across_sessions(run_dir, config, state)
    result = evaluate_path(run_dir, episodes=1, quiet=True)
    assert result["episodes"] == 1 and 0.0 <= result["success_rate"] <= 1.0
    assert result["policy"] == "deterministic"
    assert ("oracle_agreement" in result) == (algo == "relmogen-d")  # SGP-D against the task's oracle
    assert 0.0 <= result.get("oracle_agreement", 0.0) <= 1.0
    sampled = evaluate_path(run_dir, episodes=1, quiet=True, stochastic=True)  # sampled / epsilon-greedy
    assert sampled["policy"] == "stochastic" and list((run_dir / "eval").glob("*_stochastic_episode_*.json"))
    if algo == "relmogen-d":
        assert 0.0 < sampled["epsilon"] <= 1.0
    if algo.startswith("relmogen"):
        skipping = evaluate_path(run_dir, episodes=1, quiet=True, skip_no_ops=True)
        assert skipping["policy"] == "deterministic-skip-no-ops"
        assert list((run_dir / "eval").glob("*_1ep_skip_no_ops_episode_*_seed0.json"))
        if algo == "relmogen-r":  # it samples after no-ops; --stochastic samples everywhere already
            with pytest.raises(ValueError, match="use one of them"):
                evaluate_path(run_dir, episodes=1, quiet=True, skip_no_ops=True, stochastic=True)
    else:
        with pytest.raises(ValueError, match="needs relmogen-d or relmogen-r"):
            evaluate_path(run_dir, episodes=1, quiet=True, skip_no_ops=True)
    assert list((run_dir / "eval").glob("*.json"))
    if algo == "relmogen-d":
        figures = q_map_figures_for_checkpoint(run_dir, tmp_path / "qmap", states=1)
        assert len(figures) == 1 and imageio.imread(figures[0]).shape[0] > 100
    else:
        assert_exported_actor_acts_like_the_model(run_dir, tmp_path / "shipped")


def test_resume_with_a_changed_schedule_grows_the_replay_buffer_and_logs_the_change(tmp_path):
    config = resolve_config("PointNav", "relmogen-d", seed=0, preset="tiny", episodes=2)
    run_dir = train(config, tmp_path, quiet=True)
    stored = read_replay_file(latest_replay(run_dir))
    transitions = stored.pos * stored.n_envs
    bigger = 2 * config.algo_params.buffer_size
    resume(run_dir, quiet=True, episodes=3, overrides=["algo.exploration_final_eps=0.5", f"algo.buffer_size={bigger}"])
    saved = read_config(run_dir / "config.yaml")
    assert saved.algo_params.exploration_final_eps == 0.5 and saved.algo_params.buffer_size == bigger
    model = RelmogenDQN.load(latest_checkpoint(run_dir) / "model.zip")
    assert model.exploration_final_eps == 0.5
    grown = read_replay_file(latest_replay(run_dir))
    assert grown.buffer_size * grown.n_envs == bigger and grown.pos * grown.n_envs > transitions
    assert np.array_equal(grown.rewards[: stored.pos], stored.rewards[: stored.pos])  # the old ones, first
    log = read_resume_log(run_dir)
    assert log == [dict(log[0], from_episode=2, episodes=3,
                        set=["algo.exploration_final_eps=0.5", f"algo.buffer_size={bigger}"])]
    with pytest.raises(ValueError, match="when resuming"):
        resume(run_dir, quiet=True, overrides=["env.image_size=128"])
    assert (run_dir / "done.json").is_file()  # a refused change leaves the run as it was


def test_a_run_resumed_without_its_replay_collects_learning_starts_transitions_before_learning(tmp_path):
    config = resolve_config("PointNav", "relmogen-d", seed=0, preset="tiny", episodes=2)
    run_dir = train(config, tmp_path, quiet=True)
    for folder in (run_dir / "checkpoints").glob("replay_*"):  # carried to a new machine without it
        shutil.rmtree(folder)
    (run_dir / "checkpoints" / "latest_replay").unlink()
    timesteps = json.loads((latest_checkpoint(run_dir) / "state.json").read_text())["timesteps"]
    resume(run_dir, quiet=True, episodes=3)
    (entry,) = [entry for entry in read_resume_log(run_dir) if "replay" in entry]
    assert entry["replay"] == "empty" and entry["from_episode"] == 2
    assert entry["learning_starts"] == timesteps + config.algo_params.learning_starts
    assert RelmogenDQN.load(latest_checkpoint(run_dir) / "model.zip").learning_starts == entry["learning_starts"]
    assert episodes_in(run_dir) == [1, 2, 3]


def test_demonstrations_are_added_once_and_topped_up_on_resume(tmp_path):
    config = resolve_config("ButtonDoorNav", "relmogen-d", seed=0, preset="tiny", episodes=1,
                            overrides=["algo.demo_episodes=2"])
    run_dir = train(config, tmp_path, quiet=True)
    log = [json.loads(line) for line in (run_dir / "demonstrations.jsonl").read_text().splitlines()]
    assert len(log) == 1 and log[0]["at_episode"] == 0 and log[0]["episodes"] >= 2
    state = json.loads((latest_checkpoint(run_dir) / "state.json").read_text())
    assert state["demo_episodes"] == log[0]["episodes"]
    assert state["timesteps"] == 10  # one tiny-preset episode of the policy; demonstrations are not counted
    resume(run_dir, quiet=True, episodes=2)  # same target: nothing added
    assert len((run_dir / "demonstrations.jsonl").read_text().splitlines()) == 1
    resume(run_dir, quiet=True, episodes=3, overrides=[f"algo.demo_episodes={state['demo_episodes'] + 2}"])
    log = [json.loads(line) for line in (run_dir / "demonstrations.jsonl").read_text().splitlines()]
    assert len(log) == 2 and log[1]["at_episode"] == 2 and log[1]["episodes"] >= 2
    with pytest.raises(ValueError, match="needs a subgoal policy"):
        resolve_config("PointNav", "sac", preset="tiny", episodes=1, overrides=["algo.demo_episodes=1"])


def test_kept_demonstrations_outlive_a_full_ring_and_a_resume(tmp_path):
    config = resolve_config("ButtonDoorNav", "relmogen-d", seed=0, preset="tiny", episodes=3,
                            overrides=["algo.demo_episodes=2", "algo.demo_keep=true", "algo.demo_margin_weight=1",
                                       "algo.buffer_size=40", "algo.n_step_returns=3"])
    run_dir = train(config, tmp_path, quiet=True)  # about 20 demonstration rows and 30 policy rows in 40
    buffer = read_replay_file(latest_replay(run_dir))
    demo_rows = int(buffer.demo.sum())
    assert buffer.full and buffer.keep_demonstrations and demo_rows >= 2
    assert buffer.n_step_returns == 3  # set by the algorithm before its first sample
    assert buffer.demo[:demo_rows].all()  # the first rows, never overwritten
    kept = buffer.actions[:demo_rows].copy()
    resume(run_dir, quiet=True, episodes=5)
    buffer = read_replay_file(latest_replay(run_dir))
    np.testing.assert_array_equal(buffer.actions[:demo_rows], kept)
    assert int(buffer.demo.sum()) == demo_rows


def test_the_push_frame_reaches_every_environment_of_a_relmogen_d_run():
    config = resolve_config("ArrangeKitchenMM", "relmogen-d", preset="tiny", overrides=["env.push_frame=surface"])
    assert env_kwargs(config, arm_collision=True)["push_frame"] == "surface"  # training, evaluation, Q maps
    assert "push_frame" not in env_kwargs(resolve_config("PointNav", "relmogen-r", preset="tiny"), arm_collision=True)
    with pytest.raises(ValueError, match="push_frame"):
        resolve_config("PointNav", "relmogen-d", preset="tiny", overrides=["env.push_frame=tool"])


def test_tasks_that_count_items_log_items_closed_per_episode(tmp_path):
    config = resolve_config("ArrangeKitchenMM", "relmogen-d", seed=0, preset="tiny", episodes=2,
                            overrides=["env.episode_steps=3"])
    run_dir = train(config, tmp_path, quiet=True)
    closed = [float(row["closed_10"]) for row in csv.DictReader(open(run_dir / "episodes.csv", newline=""))]
    assert len(closed) == 2 and all(0 <= count <= 8 for count in closed)
    scalars = EventAccumulator(str(run_dir / "tb")).Reload().Scalars("charts/closed_10")
    assert [event.value for event in scalars] == closed


def assert_exported_actor_acts_like_the_model(run_dir: Path, out: Path):
    model, config, _ = load_policy(run_dir, device="cpu")
    export_actor(model, config, out, {"run": run_dir.name})
    env, shipped = open_shipped(out)
    try:
        obs, _ = env.reset(seed=3)
        expected = model.predict(obs, deterministic=True)[0]
        assert np.array_equal(shipped.act(obs), expected)  # the weights as trained: the same action
        assert shipped.provenance["run"] == run_dir.name and shipped.config == config
    finally:
        env.close()


def test_resuming_an_older_episode_log_keeps_its_rows_and_adds_the_new_columns(tmp_path):
    log = tmp_path / "episodes.csv"
    log.write_text("episode,timesteps,wall_time_s,return,length,success\n1,25,1.0,0.5,25,0.0\n2,50,2.0,0.7,25,1.0\n"
                   "3,75,3.0,0.1,25,0.0\n")
    truncate_episode_log(log, episodes=2)
    rows = list(csv.DictReader(open(log, newline="")))
    assert list(rows[0]) == EPISODE_FIELDS and "base_fraction" in EPISODE_FIELDS
    assert [(r["episode"], r["return"], r["base_fraction"]) for r in rows] == [("1", "0.5", ""), ("2", "0.7", "")]


def signal_when(cmd: list[str], out: Path, ready, sig: int = signal.SIGKILL,
                timeout_s: float = 240) -> tuple[Path, int, str]:
    """Start a training command and send it ``sig`` as soon as ``ready(run_dir)``; returns the run
    dir, the command's exit code and its stderr."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + timeout_s
    try:
        while time.time() < deadline:
            runs = list(out.glob("PointNav__*"))
            if runs and ready(runs[0]):
                os.kill(proc.pid, sig)
                _, stderr = proc.communicate(timeout=120)
                return runs[0], proc.returncode, stderr
            time.sleep(0.05)
        raise AssertionError("the run never reached the state to signal it in")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def kill_9_when(cmd: list[str], out: Path, ready) -> Path:
    return signal_when(cmd, out, ready)[0]


def test_resume_after_kill_9_loses_at_most_one_checkpoint_interval(tmp_path):
    cmd = [sys.executable, "-m", "relmogen.cli", "train", "--task", "PointNav", "--algo", "sac", "--preset", "tiny",
           "--episodes", "1000", "--out", str(tmp_path), "--quiet", "--set", "run.eval_every_episodes=1000"]
    run_dir = kill_9_when(cmd, tmp_path, lambda run: latest_checkpoint(run) is not None and len(episodes_in(run)) >= 4)
    saved = json.loads((latest_checkpoint(run_dir) / "state.json").read_text())["episodes"]
    logged = len(episodes_in(run_dir))
    assert logged - saved <= 1  # checkpoint every episode in the tiny preset
    resume(run_dir, quiet=True, episodes=saved + 3)
    assert episodes_in(run_dir) == list(range(1, saved + 4))


def test_kill_9_between_replay_saves_keeps_the_newer_model_and_the_older_replay(tmp_path):
    cmd = [sys.executable, "-m", "relmogen.cli", "train", "--task", "PointNav", "--algo", "relmogen-r", "--preset",
           "tiny", "--episodes", "1000", "--out", str(tmp_path), "--quiet", "--set", "run.eval_every_episodes=1000",
           "--set", "run.replay_every_episodes=3", "--set", "algo.buffer_size=1000"]
    def between_replay_saves(run: Path) -> bool:
        checkpoint = latest_checkpoint(run)
        return checkpoint is not None and json.loads((checkpoint / "state.json").read_text())["episodes"] in (4, 5)

    run_dir = kill_9_when(cmd, tmp_path, between_replay_saves)
    model_state = json.loads((latest_checkpoint(run_dir) / "state.json").read_text())
    replay_state = json.loads((latest_replay(run_dir).parent / "state.json").read_text())
    assert replay_state["episodes"] == 3 < model_state["episodes"]
    assert len(episodes_in(run_dir)) - model_state["episodes"] <= 1  # the model: one checkpoint interval
    replay = read_replay_file(latest_replay(run_dir))
    # the replay: everything up to its own save (SB3 stores a step's transition after the callback
    # that saved it, so the saving step's own transition is not in it)
    assert replay.size() == replay_state["timesteps"] - 1
    assert replay.observations["depth"].dtype == np.float16 and replay.observations["rgb"].dtype == np.uint8
    resume(run_dir, quiet=True, episodes=model_state["episodes"] + 1)
    assert episodes_in(run_dir) == list(range(1, model_state["episodes"] + 2))


def test_sigterm_stops_with_the_model_and_the_replay_saved_and_resume_continues(tmp_path):
    cmd = [sys.executable, "-m", "relmogen.cli", "train", "--task", "PointNav", "--algo", "relmogen-r", "--preset",
           "tiny", "--episodes", "1000", "--out", str(tmp_path), "--quiet", "--set", "run.eval_every_episodes=1000",
           "--set", "run.replay_every_episodes=1000", "--set", "algo.buffer_size=1000"]
    run_dir, exit_code, stderr = signal_when(
        cmd, tmp_path, lambda run: latest_checkpoint(run) is not None and len(episodes_in(run)) >= 2, signal.SIGTERM)
    assert exit_code == 130, stderr
    model_state = json.loads((latest_checkpoint(run_dir) / "state.json").read_text())
    replay_state = json.loads((latest_replay(run_dir).parent / "state.json").read_text())
    assert (f"relmogen: stopped by SIGTERM at episode {model_state['episodes']} of 1000; model and replay saved; "
            f"continue with: relmogen train --resume {run_dir}") == stderr.strip().splitlines()[-1]
    assert replay_state == model_state and model_state["episodes"] >= 2  # the replay's only save: the stop's
    assert read_replay_file(latest_replay(run_dir)).size() >= model_state["episodes"]
    resume(run_dir, quiet=True, episodes=model_state["episodes"] + 1)
    assert episodes_in(run_dir) == list(range(1, model_state["episodes"] + 2))


@pytest.fixture(scope="module")
def preset_file_run(tmp_path_factory):
    """A relmogen-r PointNav run from a preset file (tiny, evaluated every 2 episodes) trained for
    4 episodes through the CLI, then resumed to 5."""
    root = tmp_path_factory.mktemp("preset_file_run")
    tree = load_preset("tiny")
    tree["run"]["eval_every_episodes"] = 2
    preset = root / "tiny_eval2.yaml"
    preset.write_text(yaml.safe_dump(tree))
    assert main(["train", "--task", "PointNav", "--algo", "relmogen-r", "--preset", str(preset), "--episodes", "4",
                 "--out", str(root / "runs"), "--quiet"]) == 0
    (run_dir,) = (root / "runs").iterdir()
    assert main(["train", "--resume", str(run_dir), "--episodes", "5", "--quiet"]) == 0
    return preset, run_dir


def test_a_run_from_a_preset_file_records_the_file_and_resumes(preset_file_run):
    preset, run_dir = preset_file_run
    config = read_config(run_dir / "config.yaml")
    assert config.preset == str(preset) and config.run.eval_every_episodes == 2
    assert episodes_in(run_dir) == [1, 2, 3, 4, 5]


def test_the_best_periodic_evaluation_keeps_its_model_as_checkpoints_best(preset_file_run):
    _, run_dir = preset_file_run
    evaluations = [json.loads(line) for line in (run_dir / "eval_during_training.jsonl").read_text().splitlines()]
    assert [evaluation["episode"] for evaluation in evaluations] == [2, 4]
    assert (evaluations[0]["training_seed"], evaluations[0]["eval_seed"]) == (0, 10_002)
    expected = max(evaluations, key=evaluation_rank)  # the first of equals: a tie keeps the earlier model
    best = best_checkpoint(run_dir)
    state = json.loads((best / "state.json").read_text())
    assert best.name == f"best_{expected['episode']:07d}" and state["episodes"] == expected["episode"]
    assert state["evaluation"] == expected
    assert sorted(path.name for path in best.iterdir()) == ["config.yaml", "model.zip", "state.json"]  # no replay
    assert [path.name for path in (run_dir / "checkpoints").glob("best_*")] == [best.name]
    # the pointer files name their checkpoint wherever a checkpoint folder is accepted
    assert resolve_checkpoint(run_dir / "checkpoints" / "best") == (best, run_dir)
    assert resolve_checkpoint(run_dir / "checkpoints" / "latest") == (latest_checkpoint(run_dir), run_dir)


def test_a_fixed_eval_seed_plays_the_same_validation_block_and_keeps_every_evaluated_model(tmp_path):
    assert main(["train", "--task", "PointNav", "--algo", "relmogen-r", "--preset", "tiny", "--episodes", "2",
                 "--out", str(tmp_path), "--quiet", "--set", "run.eval_every_episodes=1",
                 "--set", "run.eval_seed=777", "--set", "run.keep_evaluated=true"]) == 0
    (run_dir,) = tmp_path.iterdir()
    evaluations = [json.loads(line) for line in (run_dir / "eval_during_training.jsonl").read_text().splitlines()]
    assert [(evaluation["episode"], evaluation["eval_seed"]) for evaluation in evaluations] == [(1, 777), (2, 777)]
    kept = sorted((run_dir / "checkpoints").glob("evaluated_*"))
    assert [folder.name for folder in kept] == ["evaluated_0000001", "evaluated_0000002"]
    for folder, evaluation in zip(kept, evaluations):
        assert json.loads((folder / "state.json").read_text())["evaluation"] == evaluation
        assert resolve_checkpoint(run_dir, folder.name) == (folder, run_dir)  # eval --checkpoint evaluated_...


def test_evaluations_rank_by_success_then_items_closed_then_return():
    evaluations = [{"success_rate": 0.1, "mean_return": -5.0}, {"success_rate": 0.0, "closed_10": 3.0, "mean_return": 2.0},
                   {"success_rate": 0.0, "closed_10": 3.0, "mean_return": 1.0}, {"success_rate": 0.0, "closed_10": 2.0},
                   {"mean_return": 0.5}]
    assert sorted(evaluations, key=evaluation_rank, reverse=True) == [evaluations[i] for i in (0, 1, 2, 3, 4)]


def test_eval_picks_the_checkpoint_names_it_and_its_seeds_and_records_a_video(preset_file_run, tmp_path, capsys):
    _, run_dir = preset_file_run
    best, latest = best_checkpoint(run_dir), latest_checkpoint(run_dir)
    assert main(["eval", str(run_dir), "--checkpoint", "best", "--episodes", "1", "--seed", "7",
                 "--video", str(tmp_path / "out.gif"), "--json"]) == 0
    stdout = capsys.readouterr().out.strip()
    result = json.loads(stdout)  # stdout is the JSON alone (the progress bar goes to stderr)
    assert (result["checkpoint"], result["checkpoint_episode"]) == (best.name, int(best.name.split("_")[1]))
    assert (result["eval_seed"], result["episodes"], result["training_seed"]) == (7, 1, 0) and "seed" not in result
    frames = imageio.mimread(result["video"])
    assert len(frames) > 1 and frames[0].shape[:2] == (VIDEO_SIZE[1], VIDEO_SIZE[0])
    assert main(["eval", str(run_dir), "--episodes", "1", "--seed", "7", "--json"]) == 0
    assert main(["eval", str(run_dir), "--checkpoint", str(latest), "--episodes", "1", "--seed", "8", "--json"]) == 0
    setting = "eval_office_A_rrt_connect_rrt_connect_collision-on_1ep"
    assert sorted(path.name for path in (run_dir / "eval").glob("*.json")) == sorted(
        [f"{setting}_{best.name}_seed7.json", f"{setting}_{latest.name}_seed7.json", f"{setting}_{latest.name}_seed8.json"])
    reference = final_evaluation(run_dir)  # of the latest checkpoint, the newest of equal size
    assert (reference["checkpoint"], reference["eval_seed"]) == (latest.name, 8)
    # another base goal rule (the run's is strict): named in the file, kept beside the reference
    assert main(["eval", str(run_dir), "--episodes", "1", "--seed", "9", "--base-goal", "nearest_reachable",
                 "--json"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert result["base_goal"] == "nearest_reachable"
    assert (run_dir / "eval" / ("eval_office_A_rrt_connect_rrt_connect_goal-nearest_reachable_collision-on_1ep_"
                                f"{latest.name}_seed9.json")).is_file()
    assert final_evaluation(run_dir)["eval_seed"] == 8
    # another base goal clearance (the run's is 0): named in the file, not the reference either
    assert main(["eval", str(run_dir), "--episodes", "1", "--seed", "10", "--base-goal-clearance", "0.1",
                 "--json"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert result["base_goal_clearance"] == 0.1
    assert (run_dir / "eval" / ("eval_office_A_rrt_connect_rrt_connect_clearance-0.10_collision-on_1ep_"
                                f"{latest.name}_seed10.json")).is_file()
    assert final_evaluation(run_dir)["eval_seed"] == 8
    with pytest.raises(SystemExit):
        main(["eval", str(run_dir), "--base-goal-clearance", "-0.1"])
    # critic selection: its own policy and file, never the reference; not with --stochastic
    assert main(["eval", str(run_dir), "--episodes", "1", "--seed", "11", "--critic-select", "4", "--json"]) == 0
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert result["policy"] == "deterministic-critic-select-4"
    assert (run_dir / "eval" / f"{setting}_critic_select4_{latest.name}_seed11.json").is_file()
    assert final_evaluation(run_dir)["eval_seed"] == 8
    assert main(["eval", str(run_dir), "--episodes", "1", "--critic-select", "4", "--stochastic"]) == 2
    assert "--critic-select" in capsys.readouterr().err


# ------------------------------------------------------------------ environment workers
class _ToyEnv(gym.Env):
    """A one-number environment whose ``step`` raises, hangs or works, as asked."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def __init__(self, behaviour: str = "ok"):
        self.behaviour = behaviour

    def reset(self, seed=None, options=None):
        return np.zeros(1, np.float32), {}

    def step(self, action):
        if self.behaviour == "raise":
            raise RuntimeError("the planner lost its scene")
        if self.behaviour == "hang":
            time.sleep(3600)
        return np.zeros(1, np.float32), 0.0, False, False, {}


def _toy_venv(behaviours: list[str], tmp_path: Path, timeout_s: float = 600.0) -> GuardedSubprocVecEnv:
    log = tmp_path / WORKER_ERRORS
    fns = [lambda b=b: worker_env(_ToyEnv(b), error_log=str(log)) for b in behaviours]
    return GuardedSubprocVecEnv(fns, start_method="fork", timeout_s=timeout_s, error_log=log)


def test_a_worker_exception_is_logged_and_names_its_worker_and_error(tmp_path):
    venv = _toy_venv(["ok", "raise"], tmp_path)
    venv.reset()
    with pytest.raises(EnvWorkerError) as caught:
        venv.step(np.zeros((2, 1), np.float32))
    assert (caught.value.index, caught.value.reason) == (1, "RuntimeError: the planner lost its scene")
    started = time.time()
    venv.close()  # the surviving worker is ended, not waited on
    assert time.time() - started < 10 and not any(process.is_alive() for process in venv.processes)
    log = (tmp_path / WORKER_ERRORS).read_text()
    assert log.startswith(f"=== worker pid {venv.processes[1].pid}: step") and "Traceback" in log
    assert last_logged_error(tmp_path / WORKER_ERRORS, venv.processes[1].pid) == caught.value.reason


def test_a_stuck_worker_times_out_and_a_killed_one_names_the_signal(tmp_path):
    venv = _toy_venv(["hang", "ok"], tmp_path, timeout_s=1.5)
    venv.reset()
    started = time.time()
    with pytest.raises(EnvWorkerError, match=r"environment worker 0 died: no reply in 1.5 s"):
        venv.step(np.zeros((2, 1), np.float32))
    assert time.time() - started < 10
    venv.close()
    assert not any(process.is_alive() for process in venv.processes)
    venv = _toy_venv(["ok", "ok"], tmp_path)
    venv.reset()
    os.kill(venv.processes[1].pid, signal.SIGKILL)
    with pytest.raises(EnvWorkerError, match="environment worker 1 died: killed by signal SIGKILL"):
        venv.step(np.zeros((2, 1), np.float32))
    venv.close()


def test_worker_environments_keep_the_oracle_labels_inside_the_error_log():
    config = resolve_config("ButtonDoorNav", "relmogen-d", preset="tiny",
                            overrides=["env.n_envs=2", "algo.oracle_labels=true", "algo.demo_margin_weight=1"])
    venv = make_training_env(config)
    try:
        assert isinstance(venv, GuardedSubprocVecEnv)
        venv.reset()
        labels = venv.env_method("oracle_label")  # through WorkerErrorLog to OracleLabels
        assert len(labels) == 2 and all(isinstance(label, (int, np.integer)) for label in labels)
    finally:
        venv.close()


def test_a_killed_environment_worker_stops_the_run_with_a_checkpoint_and_resume_continues(tmp_path):
    cmd = [sys.executable, "-m", "relmogen.cli", "train", "--task", "PointNav", "--algo", "relmogen-r", "--preset",
           "tiny", "--episodes", "1000", "--out", str(tmp_path), "--quiet", "--set", "env.n_envs=2",
           "--set", "run.eval_every_episodes=1000"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline, workers = time.time() + 180, []
        while time.time() < deadline:  # forkserver: the workers are the trainer's grandchildren
            runs = list(tmp_path.glob("PointNav__*"))
            workers = [g for c in psutil.Process(proc.pid).children() for g in c.children()]
            if runs and len(workers) == 2 and len(episodes_in(runs[0]) if (runs[0] / "episodes.csv").is_file()
                                                 else []) >= 2:
                break
            time.sleep(0.1)
        else:
            raise AssertionError("the run never logged two episodes with two workers")
        workers[0].kill()
        killed_at = time.time()
        _, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert time.time() - killed_at < 60 and proc.returncode == 1
    (run_dir,) = runs
    line = stderr.strip().splitlines()[-1]
    saved = json.loads((latest_checkpoint(run_dir) / "state.json").read_text())["episodes"]
    assert re.fullmatch(rf"relmogen: error: environment worker [01] died: killed by signal SIGKILL; checkpoint at "
                        rf"episode {saved} written; continue with: relmogen train --resume {re.escape(str(run_dir))}",
                        line), line
    assert json.loads((latest_replay(run_dir).parent / "state.json").read_text())["episodes"] == saved
    assert saved >= 2 and not (run_dir / "done.json").exists()
    assert main(["train", "--resume", str(run_dir), "--episodes", str(saved + 2), "--quiet"]) == 0
    assert episodes_in(run_dir) == list(range(1, saved + 3))


@pytest.mark.parametrize("n_envs", [1, 2])  # 2: worker processes, whose CPU the stop reason must count too
def test_a_cpu_time_budget_stops_the_run_once_trainer_and_workers_spent_it(tmp_path, n_envs):
    from relmogen.experiments.budgets import process_tree_cpu_seconds

    # the process's CPU so far counts too (a new process starts at 0); starting workers costs ~10 CPU s
    budget_s = process_tree_cpu_seconds() + (5.0 if n_envs == 1 else 25.0)
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=1000,
                            overrides=[f"max_cpu_hours={budget_s / 3600}", "run.eval_every_episodes=1000",
                                       f"env.n_envs={n_envs}"])
    run_dir = train(config, tmp_path, quiet=True)
    done = json.loads((run_dir / "done.json").read_text())
    assert 1 <= done["episodes"] < 1000 and done["cpu_time_s"] >= budget_s
    assert done["stop_reason"].startswith(f"stopped by the CPU-time limit (max_cpu_hours {budget_s / 3600:g}) "
                                          f"at episode {done['episodes']} of 1000")
    assert read_config(run_dir / "config.yaml").max_cpu_hours == pytest.approx(budget_s / 3600)


def test_a_time_limit_stops_the_run_and_the_stop_reason_names_it(tmp_path, capsys):
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=1000, max_hours=2 / 3600,
                            overrides=["run.eval_every_episodes=1000"])
    run_dir = train(config, tmp_path, quiet=True)
    episodes = json.loads((run_dir / "done.json").read_text())["episodes"]
    assert re.fullmatch(rf"stopped by the time limit \(--max-hours {2 / 3600:g}\) at episode {episodes} of 1000, "
                        r"after 0:00:0[2-9]", stop_reason(run_dir)), stop_reason(run_dir)
    # resumed as it was: one line naming the limit and how to raise it, nothing trained
    assert main(["train", "--resume", str(run_dir), "--quiet"]) == 0
    (line,) = capsys.readouterr().err.splitlines()
    assert f"its time limit (--max-hours {2 / 3600:g}; 0:00:0" in line and line.endswith(
        f"--resume {run_dir} --max-hours H (H > {episode_state(run_dir)['wall_time_s'] / 3600:.3g}, a total from "
        "the run's start)")
    assert episodes_in(run_dir) == list(range(1, episodes + 1))
    # raised: it continues for the time added
    assert main(["train", "--resume", str(run_dir), "--quiet", "--max-hours", str(4 / 3600)]) == 0
    assert capsys.readouterr().err.startswith("relmogen: stopped by the time limit (--max-hours")
    assert len(episodes_in(run_dir)) > episodes and episodes_in(run_dir) == list(range(1, len(episodes_in(run_dir)) + 1))


def episode_state(run_dir: Path) -> dict:
    return json.loads((latest_checkpoint(run_dir) / "state.json").read_text())


def test_resuming_a_run_that_spent_its_budget_names_the_budget_and_trains_only_when_it_is_raised(tmp_path, capsys):
    assert main(["train", "--task", "PointNav", "--algo", "relmogen-r", "--preset", "tiny", "--episodes", "2",
                 "--out", str(tmp_path), "--quiet", "--set", "run.eval_every_episodes=1000"]) == 0
    run_dir = Path(capsys.readouterr().out.strip())
    files = {path: path.stat().st_mtime_ns for path in run_dir.rglob("*") if path.is_file()}
    hints = {(): "its episode budget (2 of 2 episodes); nothing trained; to continue: "
                 f"relmogen train --resume {run_dir} --episodes N (N > 2)",
             ("--set", "max_cpu_hours=1e-6"): "and its CPU-time limit (max_cpu_hours 1e-06; ",
             ("--max-hours", "1e-6"): "and its time limit (--max-hours 1e-06; 0:00:0"}
    for args, hint in hints.items():
        assert main(["train", "--resume", str(run_dir), "--quiet", *args]) == 0
        out, err = capsys.readouterr()
        (line,) = err.splitlines()
        assert line.startswith("relmogen: the run already reached its episode budget") and hint in line, line
        assert out == f"{run_dir}\n"
    assert "--set max_cpu_hours=H (H > " in line or "--max-hours H (H > " in line
    # nothing was trained, written or logged: not the config, not resumes.jsonl, not done.json
    assert {path: path.stat().st_mtime_ns for path in run_dir.rglob("*") if path.is_file()} == files
    assert main(["train", "--resume", str(run_dir), "--quiet", "--episodes", "3"]) == 0
    assert capsys.readouterr().err.startswith("relmogen: stopped by the episode budget: 3 of 3 episodes")
    assert episodes_in(run_dir) == [1, 2, 3]


def test_a_run_killed_between_its_last_checkpoint_and_done_json_is_finished_by_resume(tmp_path):
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=2,
                            overrides=["run.eval_every_episodes=1000"])
    run_dir = train(config, tmp_path, quiet=True)
    done = json.loads((run_dir / "done.json").read_text())
    (run_dir / "done.json").unlink()
    assert resume(run_dir, quiet=True) == run_dir
    finished = json.loads((run_dir / "done.json").read_text())
    # the reason's elapsed time is the checkpoint's (the first end counted its replay save too)
    assert finished.pop("stop_reason").split(" in ")[0] == done["stop_reason"].split(" in ")[0]
    assert finished == episode_state(run_dir)


def test_every_end_of_training_saves_the_replay_with_the_model(tmp_path):
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=3,
                            overrides=["run.eval_every_episodes=1000", "run.replay_every_episodes=100"])
    run_dir = train(config, tmp_path, quiet=True)
    replay_folder = latest_replay(run_dir).parent
    assert replay_folder.name == "replay_0000003" and latest_checkpoint(run_dir).name == "episode_0000003"
    assert json.loads((replay_folder / "state.json").read_text()) == episode_state(run_dir)
    # every transition, the last step's too (finish_stopped_step: SB3 would store it after the callback)
    assert read_replay_file(latest_replay(run_dir)).size() == episode_state(run_dir)["timesteps"]


@pytest.fixture
def monitor(tmp_path):
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=100, max_hours=0.1)
    (tmp_path / "eval_during_training.jsonl").write_text(
        json.dumps({"episode": 20, "success_rate": 0.25}) + "\n" + json.dumps({"episode": 40, "success_rate": 0.5}))
    monitor = TrainingMonitor(tmp_path, config, {"episodes": 40, "timesteps": 0, "wall_time_s": 0.0}, quiet=True)
    yield monitor
    monitor.close()


def test_progress_estimates_the_time_left_from_this_session_and_the_time_limit(monitor):
    assert monitor.remaining_seconds() is None  # no episode yet this session
    monitor.session_start -= 100.0
    monitor.state["episodes"] += 10  # 10 episodes in 100 s: 50 left take 500 s, the 0.1 h limit ends in 260 s
    assert monitor.remaining_seconds() == pytest.approx(260.0, abs=1.0)
    monitor.config = monitor.config.model_copy(update={"max_hours": None})
    assert monitor.remaining_seconds() == pytest.approx(500.0, abs=5.0)


def test_progress_shows_the_latest_periodic_evaluation_of_a_resumed_run(monitor):
    assert "eval SR 0.50 (episode 40)" in monitor._stats(1.0)
    monitor.successes = [1.0, 0.0]
    assert monitor._stats(1.0).startswith("SR 0.50 (last 2)")


def test_a_run_on_state_observations_learns_and_evaluates(tmp_path):
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=3,
                            overrides=["env.obs_mode=state", "run.eval_every_episodes=1000"])
    run_dir = train(config, tmp_path, quiet=True)
    model, _, _ = load_policy(run_dir, device="cpu")
    assert set(model.observation_space.spaces) == {"state"}
    result = evaluate_path(run_dir, episodes=1, quiet=True, save=False)
    assert result["episodes"] == 1 and read_config(run_dir / "config.yaml").env.obs_mode == "state"
    tags = EventAccumulator(str(run_dir / "tb")).Reload().Tags()["scalars"]
    assert "losses/critic_loss" in tags  # gradient steps ran on the state vector
