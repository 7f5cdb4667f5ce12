"""Fine-tuning: a new run that starts from another run's weights (and, when asked, its replay).

``relmogen train --init-from RUN_OR_CHECKPOINT [--init-replay]`` is the paper's fine-tuning to a
new scene (with ``env.second_scene``: half of the training environments there) or a new robot
(``--robot``). What was loaded is recorded in the new run's ``init_from.json``.
"""

from __future__ import annotations

import json
from pathlib import Path

from relmogen.agents.replay import resize_replay_buffer
from relmogen.experiments.config import TrainConfig, read_config

INIT_LOG = "init_from.json"


def init_source(config: TrainConfig, path: Path) -> tuple[Path, Path]:
    """(checkpoint folder, run directory) of ``--init-from``: a run directory's latest checkpoint
    or a checkpoint folder; its run must have trained the same algorithm."""
    from relmogen.experiments.loading import resolve_checkpoint

    folder, run_dir = resolve_checkpoint(Path(path), "latest")
    source = read_config(run_dir / "config.yaml")
    if source.algo != config.algo:
        raise ValueError(f"--init-from {path}: that run trained {source.algo}, this one trains {config.algo}; "
                         "the algorithm must be the same")
    return folder, run_dir


def _space_difference(given, expected) -> str:
    """Which parts of two (Dict) spaces differ, e.g. ``task_obs (33,) vs (55,)``."""
    if hasattr(given, "spaces") and hasattr(expected, "spaces"):
        keys = sorted(set(given.spaces) | set(expected.spaces))
        return ", ".join(f"{key} {getattr(given.spaces.get(key), 'shape', None)} vs "
                         f"{getattr(expected.spaces.get(key), 'shape', None)}"
                         for key in keys if given.spaces.get(key) != expected.spaces.get(key))
    return f"{given} vs {expected}"


def initialise_from(model, config: TrainConfig, folder: Path, source_run: Path, with_replay: bool = False) -> dict:
    """Load the weights (networks, optimisers, SAC's temperature) of the model in ``folder``
    into ``model``, and with ``with_replay`` the latest replay buffer of ``source_run``; a
    ValueError when the observation or action spaces (or the replay's environment count) differ.
    Returns what was loaded, for ``init_from.json``."""
    from stable_baselines3.common.save_util import load_from_zip_file, recursive_setattr

    from relmogen.experiments.checkpoints import checkpoint_state, latest_replay, load_replay

    data, params, variables = load_from_zip_file(Path(folder) / "model.zip", device=model.device)
    for name in ("observation_space", "action_space"):
        if name in data and data[name] != getattr(model, name):
            raise ValueError(f"--init-from {folder}: its {name.replace('_', ' ')} differs from this run's "
                             f"({_space_difference(data[name], getattr(model, name))}): the task, control, "
                             "image size and robot must give the same spaces")
    model.set_parameters(params, exact_match=True, device=model.device)
    for name, value in variables.items():  # e.g. SAC's log_ent_coef, as BaseAlgorithm.load restores them
        recursive_setattr(model, f"{name}.data", value.data)
    source = read_config(Path(source_run) / "config.yaml")
    state = checkpoint_state(folder)
    record = {"run": str(Path(source_run).resolve()), "checkpoint": str(Path(folder).resolve()),
              "checkpoint_episode": state.get("episodes"), **_budget_before(state, read_init_from(source_run)),
              "task": source.task, "algo": source.algo, "robot": source.env.robot, "scene": source.env.scene,
              "second_scene": source.env.second_scene, "replay": None, "replay_transitions": 0}
    if with_replay:
        replay = latest_replay(source_run)
        if replay is None:
            raise ValueError(f"--init-replay: {source_run} has no saved replay buffer")
        load_replay(model, replay)
        if model.replay_buffer.n_envs != config.env.n_envs:
            raise ValueError(f"--init-replay: the replay buffer of {source_run} holds {model.replay_buffer.n_envs} "
                             f"environments' columns, this run has env.n_envs={config.env.n_envs}; they must match")
        resize_replay_buffer(model.replay_buffer, config.algo_params.buffer_size)
        buffer = model.replay_buffer  # size() counts rows of n_envs transitions
        record.update(replay=str(Path(replay).resolve()), replay_transitions=int(buffer.size() * buffer.n_envs))
    return record


INITIAL_BUDGET_KEYS = ("episodes", "cpu_time_s", "wall_time_s", "gradient_updates")  # state.json keys, as initial_<key>


def _budget_before(state: dict, source_init: dict | None) -> dict[str, float]:
    """What the weights had cost when loaded: the source checkpoint's episodes, CPU and wall
    seconds, plus whatever its own run had been initialised from (``initial_*`` of its log)."""
    earlier = source_init or {}
    return {f"initial_{key}": float(state[key]) + float(earlier.get(f"initial_{key}", 0.0))
            for key in INITIAL_BUDGET_KEYS if key in state}  # gradient_updates: states since 2026-12-08


def read_init_from(run_dir: Path) -> dict | None:
    """What a run was initialised from (``train --init-from``), or None for a run from scratch."""
    path = Path(run_dir) / INIT_LOG
    return json.loads(path.read_text()) if path.is_file() else None
