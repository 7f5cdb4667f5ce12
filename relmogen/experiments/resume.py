"""``relmogen train --resume RUN_DIR``: a run continues from ``checkpoints/latest`` and
``checkpoints/latest_replay``. After ``kill -9`` at any moment it loses at most one model
interval of learning and the transitions collected since the last replay save; a run killed
before its first checkpoint starts over in place. A resume may raise the budget and change the
learning schedule (``config.resumable_settings``); each change is logged to ``resumes.jsonl``."""

from __future__ import annotations

import csv
import json
import sys
import time
from pathlib import Path

import torch as th

from relmogen.agents.replay import resize_replay_buffer
from relmogen.experiments.budgets import DONE, budget_stop_reason, spent_budget_note, spent_budgets, write_done
from relmogen.experiments.checkpoints import (checkpoint_state, latest_checkpoint, latest_replay, load_replay,
                                              run_config_file)
from relmogen.experiments.config import TrainConfig, override_config, read_config, save_config
from relmogen.experiments.environments import make_training_env
from relmogen.experiments.finetune import initialise_from, read_init_from
from relmogen.experiments.models import build_model, model_class, resolve_device
from relmogen.experiments.monitor import EPISODE_FIELDS
from relmogen.experiments.session import learn

RESUME_LOG = "resumes.jsonl"


def resumed_config(run_dir: Path, episodes: int | None = None, max_hours: float | None = None,
                   overrides: list[str] = ()) -> tuple[TrainConfig, dict, dict]:
    """The run's configuration with a resume's changes: the config, the changed algorithm
    parameters (``override_config``) and the new budgets given as arguments."""
    config, changed = override_config(read_config(run_config_file(run_dir)), list(overrides))
    updates = {key: value for key, value in (("episodes", episodes), ("max_hours", max_hours)) if value is not None}
    return config.model_copy(update=updates), changed, updates


def resume_budget_note(run_dir: Path, episodes: int | None = None, max_hours: float | None = None,
                       overrides: list[str] = ()) -> str | None:
    """What ``resume`` with these arguments would say instead of training: one line naming the
    budgets the run already reached and how to raise them; None when it would train."""
    checkpoint = latest_checkpoint(Path(run_dir))
    if checkpoint is None:
        return None
    state = checkpoint_state(checkpoint)
    return spent_budget_note(Path(run_dir), resumed_config(Path(run_dir), episodes, max_hours, overrides)[0], state)


def resume(run_dir: Path, quiet: bool = False, episodes: int | None = None,
           max_hours: float | None = None, overrides: list[str] = ()) -> Path:
    """Continue a run from its latest checkpoint, optionally with a new episode budget, a new
    total wall-clock budget (hours counted from the run's start, across resumes; a total CPU
    budget through ``max_cpu_hours=H`` in ``overrides``) or changed learning parameters
    (``overrides``, ``--set`` syntax, see ``override_config``). Every change is appended to
    ``resumes.jsonl`` with the episode it took effect at. A run whose latest checkpoint already
    reached the (new) budget is left as it is (``resume_budget_note`` says why); its ``done.json``
    is written if a kill came between that checkpoint and it."""
    run_dir = Path(run_dir)
    config, changed, updates = resumed_config(run_dir, episodes, max_hours, overrides)
    checkpoint = latest_checkpoint(run_dir)
    state = checkpoint_state(checkpoint) if checkpoint else None
    if state is not None and spent_budgets(config, state):
        write_done(run_dir, state, budget_stop_reason(config, state), keep=True)
        return run_dir
    (run_dir / DONE).unlink(missing_ok=True)  # running again: not done until the session ends
    if updates or overrides:
        save_config(config, run_dir / "config.yaml")
        _log_resume(run_dir, state["episodes"] if state else 0, **updates, set=list(overrides))
    env = make_training_env(config, run_dir)
    if checkpoint is None:  # killed before the first checkpoint: start over in place
        state, model = {"episodes": 0, "timesteps": 0, "wall_time_s": 0.0}, _restarted_model(run_dir, config, env)
    else:
        model = _resumed_model(run_dir, config, checkpoint, changed, env, state)
    truncate_episode_log(run_dir / "episodes.csv", state["episodes"])
    return learn(run_dir, config, model, state, quiet)


def _restarted_model(run_dir: Path, config: TrainConfig, env):
    """A new model, from the same weights (and replay) as the run's first start if it had any."""
    model = build_model(config, env)
    init = read_init_from(run_dir)
    if init is not None:
        initialise_from(model, config, Path(init["checkpoint"]), Path(init["run"]), init["replay"] is not None)
    return model


def _resumed_model(run_dir: Path, config: TrainConfig, checkpoint: Path, changed: dict, env, state: dict):
    """The checkpoint's model on ``env`` with the changed parameters, and the run's latest replay."""
    th.set_num_threads(config.run.torch_threads)  # as build_model does: extra threads thrash a busy CPU
    model = model_class(config).load(checkpoint / "model.zip", env=env, device=resolve_device(config.device),
                                     **changed)  # SB3 rebuilds schedules and buffer from these
    replay = latest_replay(run_dir)
    if replay is not None:
        load_replay(model, replay)
    else:  # killed before its first save, or carried to another machine without it
        refill_before_learning(run_dir, model, config, state)
    resize_replay_buffer(model.replay_buffer, config.algo_params.buffer_size)
    return model


def refill_before_learning(run_dir: Path, model, config: TrainConfig, state: dict) -> None:
    """A run resumed without a replay buffer first collects ``learning_starts`` transitions, as a
    new run does (with random actions), instead of fitting batches drawn from its first few; the
    refill is logged to ``resumes.jsonl``."""
    if model.num_timesteps == 0:
        return
    model.learning_starts = model.num_timesteps + config.algo_params.learning_starts
    print(f"{run_dir}: no saved replay buffer; collecting {config.algo_params.learning_starts} transitions "
          "before learning resumes", file=sys.stderr)
    _log_resume(run_dir, state["episodes"], replay="empty", learning_starts=model.learning_starts)


def _log_resume(run_dir: Path, from_episode: int, **fields) -> None:
    """One line of ``resumes.jsonl``: the episode the resume took effect at, the time and ``fields``."""
    entry = {"from_episode": from_episode, "time": time.strftime("%Y-%m-%dT%H:%M:%S"), **fields}
    with open(run_dir / RESUME_LOG, "a") as handle:
        handle.write(json.dumps(entry) + "\n")


def read_resume_log(run_dir: Path) -> list[dict]:
    """The run's resumes, oldest first (empty for a run never resumed with changes)."""
    log = Path(run_dir) / RESUME_LOG
    return [json.loads(line) for line in log.read_text().splitlines()] if log.is_file() else []


def truncate_episode_log(path: Path, episodes: int) -> None:
    """Drop rows written after the checkpoint we resume from (they will be replayed); the file
    is rewritten with the current columns (a run logged by an older version gains the new
    ones, empty in its old rows)."""
    if not path.is_file():
        return
    with open(path, newline="") as handle:
        rows = [row for row in csv.DictReader(handle) if int(row["episode"]) <= episodes]
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=EPISODE_FIELDS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
