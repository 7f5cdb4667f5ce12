"""The checkpoint store of a run directory: model, replay, best and evaluated checkpoints, each
written under a staging name and published by atomically replacing its pointer file
(``checkpoints/latest``, ``latest_replay``, ``best``), so ``kill -9`` at any moment leaves the
previous ones intact.

The replay is written compactly (``replay.npz``, ``relmogen.agents.replay.export_replay``: filled
rows only, next observations not repeated, compressed, no pickled classes; about 15x smaller than
SB3's pickle of relmogen-d / relmogen-r replays). Runs saved before it have ``replay_buffer.pkl``,
which ``latest_replay``, ``load_replay`` and ``read_replay_file`` still take."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np

from relmogen.agents.replay import export_replay, import_replay, read_replay


CHECKPOINTS = "checkpoints"
LATEST = "latest"  # a file naming the newest complete model checkpoint folder
LATEST_REPLAY = "latest_replay"  # a file naming the newest complete replay folder
BEST = "best"  # a file naming the model folder of the best periodic evaluation so far
REPLAY_FILE = "replay.npz"  # written by write_checkpoint (export_replay)
PICKLED_REPLAY_FILE = "replay_buffer.pkl"  # SB3's save_replay_buffer: runs saved before replay.npz
REPLAY_FILES = (REPLAY_FILE, PICKLED_REPLAY_FILE)  # the one found first is loaded


def latest_checkpoint(run_dir: Path) -> Path | None:
    return _pointed_checkpoint(run_dir, LATEST)


def best_checkpoint(run_dir: Path) -> Path | None:
    """The model of the best periodic evaluation so far (``TrainingMonitor.evaluate``), or None."""
    return _pointed_checkpoint(run_dir, BEST)


def _pointed_checkpoint(run_dir: Path, pointer_name: str) -> Path | None:
    pointer = Path(run_dir) / CHECKPOINTS / pointer_name
    if not pointer.is_file():
        return None
    folder = pointer.parent / pointer.read_text().strip()
    return folder if (folder / "model.zip").is_file() else None


def best_evaluation(run_dir: Path) -> dict | None:
    """The periodic evaluation recorded with ``checkpoints/best``, or None before the first one."""
    checkpoint = best_checkpoint(run_dir)
    return json.loads((checkpoint / "state.json").read_text()).get("evaluation") if checkpoint else None


def evaluation_rank(evaluation: dict) -> tuple[float, float, float]:
    """Orders evaluations, best last: success rate, then items closed (``closed_10``), then mean
    return, so ties and tasks that never succeed are decided by the next figure."""
    return (evaluation.get("success_rate", 0.0), evaluation.get("closed_10", 0.0),
            evaluation.get("mean_return", -np.inf))


def latest_replay(run_dir: Path) -> Path | None:
    """The newest saved replay buffer file (``replay.npz``, or ``replay_buffer.pkl`` of older runs):
    its own folder (``latest_replay``), or inside the model checkpoint for runs saved before the
    two were split."""
    root = Path(run_dir) / CHECKPOINTS
    pointer = root / LATEST_REPLAY
    if pointer.is_file():
        found = _replay_file(root / pointer.read_text().strip())
        if found is not None:
            return found
    checkpoint = latest_checkpoint(run_dir)
    return _replay_file(checkpoint) if checkpoint is not None else None


def _replay_file(folder: Path) -> Path | None:
    return next((folder / name for name in REPLAY_FILES if (folder / name).is_file()), None)


def replay_buffers(model) -> dict:
    """The replay buffers of a model by name: ``{"replay": model.replay_buffer}``, or HRL4IN's two
    levels ``{"high": ..., "low": ...}``."""
    levels = {name: getattr(model, name, None) for name in ("high", "low")}
    if all(hasattr(level, "replay_buffer") for level in levels.values()):
        return {name: level.replay_buffer for name, level in levels.items()}
    return {"replay": model.replay_buffer}


def save_replay(model, path: Path) -> Path:
    """A model's replay buffer(s) as a compact ``replay.npz`` (``export_replay``)."""
    return export_replay(replay_buffers(model), path)


def load_replay(model, path: Path) -> None:
    """Load a saved replay into ``model``: a compact file in place into its buffers (which keep
    the model's device), or an older run's pickle through ``model.load_replay_buffer``."""
    path = Path(path)
    if path.suffix == ".pkl":
        model.load_replay_buffer(path)
    else:
        import_replay(path, replay_buffers(model))


def read_replay_file(path: Path):
    """A saved replay without a model, for inspection and tests: the buffer (HRL4IN's:
    ``{"high": ..., "low": ...}``) of a ``replay.npz`` (``read_replay``) or an older pickle."""
    path = Path(path)
    if path.suffix == ".pkl":
        from stable_baselines3.common.save_util import load_from_pkl

        return load_from_pkl(path)
    return read_replay(path)


def checkpoint_state(folder: Path) -> dict:
    """The ``state.json`` of a checkpoint folder (episodes, timesteps, ...); {} if it has none."""
    path = Path(folder) / "state.json"
    return json.loads(path.read_text()) if path.is_file() else {}


def write_checkpoint(run_dir: Path, model, state: dict, with_replay: bool = True) -> Path:
    """The model (and, when asked, the replay buffer in its own folder) published atomically;
    older folders of the same kind are removed once the new one is in place."""
    root = Path(run_dir) / CHECKPOINTS
    if with_replay:
        _write_folder(root, f"replay_{state['episodes']:07d}", LATEST_REPLAY,
                      lambda folder: save_replay(model, folder / REPLAY_FILE), state)
    return _write_folder(root, f"episode_{state['episodes']:07d}", LATEST,
                         lambda folder: model.save(folder / "model.zip"), state)


def write_best_checkpoint(run_dir: Path, model, state: dict) -> Path:
    """The model alone (no replay) as ``checkpoints/best_<episode>``, published atomically through
    ``checkpoints/best``; ``state["evaluation"]`` is the evaluation that made it the best."""
    return _write_folder(Path(run_dir) / CHECKPOINTS, f"best_{state['episodes']:07d}", BEST,
                         lambda folder: model.save(folder / "model.zip"), state)


def write_evaluated_checkpoint(run_dir: Path, model, state: dict) -> Path:
    """The model alone as ``checkpoints/evaluated_<episode>`` (``run.keep_evaluated``); earlier
    ones are kept, ``checkpoints/evaluated`` names the newest."""
    return _write_folder(Path(run_dir) / CHECKPOINTS, f"evaluated_{state['episodes']:07d}", "evaluated",
                         lambda folder: model.save(folder / "model.zip"), state, prune=False)


def _write_folder(root: Path, name: str, pointer: str, write, state: dict, prune: bool = True) -> Path:
    folder, staging = root / name, root / f".staging_{os.getpid()}"
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    write(staging)
    (staging / "state.json").write_text(json.dumps(state))
    if (staging / "model.zip").is_file() and (root.parent / "config.yaml").is_file():
        shutil.copy(root.parent / "config.yaml", staging)  # a model carries its settings (loading.py)
    shutil.rmtree(folder, ignore_errors=True)
    os.replace(staging, folder)
    _publish(root, folder.name, pointer)
    if prune:
        for old in root.glob(name.split("_")[0] + "_*"):
            if old.name != folder.name:
                shutil.rmtree(old, ignore_errors=True)
    return folder


def _publish(root: Path, name: str, pointer: str) -> None:
    tmp = root / f".{pointer}.tmp"
    tmp.write_text(name)
    os.replace(tmp, root / pointer)


def run_config_file(run_dir: Path) -> Path:
    """``run_dir/config.yaml``; a ValueError when ``run_dir`` is not a run directory."""
    path = Path(run_dir) / "config.yaml"
    if not path.is_file():
        raise ValueError(f"{run_dir} is not a run directory (no config.yaml); give a folder made by relmogen train")
    return path
