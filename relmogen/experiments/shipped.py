"""Trained policies shipped inside the package: export a run's actor, load it back to act.

A shipped policy is a folder with the run's resolved ``config.yaml`` and ``actor.pt``: the
SGP-R actor's weights (its image/scan/task-info encoder and the Gaussian head) as trained
(float32: a float16 copy of the Table I PushDoorNav actor moved its actions enough that the
demo's 20 episodes went from SR 0.95 to 0.80; a closed-loop policy amplifies small differences),
plus a ``provenance.json`` saying which run, checkpoint and evaluation it came from.
The critics, optimizers and replay buffer are left out: the checkpoint of a cpu-preset run is
about 19 MB of model and 600 MB of replay buffer, the actor alone is a small fraction of it.

``relmogen export RUN_DIR --out DIR`` writes one; ``relmogen demo`` loads the PushDoorNav one
from ``relmogen/policies/``; ``relmogen.load`` and ``relmogen eval`` load any
(``relmogen.experiments.loading``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
import torch as th
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.config import TrainConfig, read_config, save_config

POLICIES_DIR = Path(__file__).resolve().parent.parent / "policies"
ACTOR_FILE, CONFIG_FILE, PROVENANCE_FILE = "actor.pt", "config.yaml", "provenance.json"
SHIPPABLE_ALGOS = ("relmogen-r", "sac", "oac")


@dataclass
class ShippedPolicy:
    config: TrainConfig
    act: Callable[[dict], np.ndarray]
    provenance: dict


def export_actor(model, config: TrainConfig, out_dir: Path, provenance: dict | None = None) -> Path:
    """Write ``config.yaml``, ``actor.pt`` (the weights as trained) and ``provenance.json`` into ``out_dir``."""
    if config.algo not in SHIPPABLE_ALGOS:
        raise ValueError(f"only SAC-family actors ({', '.join(SHIPPABLE_ALGOS)}) can be exported, got {config.algo!r}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    state = {key: value.detach().cpu() for key, value in model.policy.actor.state_dict().items()}
    th.save(state, out_dir / ACTOR_FILE)
    save_config(config, out_dir / CONFIG_FILE)
    (out_dir / PROVENANCE_FILE).write_text(json.dumps(provenance or {}, indent=1))
    return out_dir


def is_exported_policy(folder: Path) -> bool:
    """Whether ``folder`` holds an exported actor (``export_actor``) rather than a run or checkpoint."""
    return (Path(folder) / ACTOR_FILE).is_file() and (Path(folder) / CONFIG_FILE).is_file()


def shipped_policy_dir(name: str) -> Path:
    folder = POLICIES_DIR / name
    if not is_exported_policy(folder):
        available = sorted(p.name for p in POLICIES_DIR.glob("*") if is_exported_policy(p))
        raise ValueError(f"no shipped policy {name!r} in {POLICIES_DIR}; available: {', '.join(available) or 'none'}")
    return folder


def _is_input_scaling(key: str) -> bool:
    """The encoder's input statistics (``InputScaling``): absent from actors exported before them,
    which then load with the identity scaling they were trained with."""
    return "_scaling." in key


def exported_model(folder: Path, config: TrainConfig, env: RelmogenEnv, device: str = "cpu"):
    """The SAC-family model ``config`` builds on ``env``'s spaces with the actor of ``folder``
    loaded (its critics untrained, a one-transition replay)."""
    from relmogen.experiments.models import build_model  # the network training builds

    small = config.model_copy(update={"device": device, "algo_params": config.algo_params.model_copy(
        update={"buffer_size": 1, "learning_starts": 0})})
    model = build_model(small, DummyVecEnv([lambda: env]))
    state = th.load(Path(folder) / ACTOR_FILE, map_location=device, weights_only=True)
    reference = model.policy.actor.state_dict()
    missing = {key for key in set(reference) - set(state) if not _is_input_scaling(key)}  # older exports
    if missing or set(state) - set(reference):
        raise ValueError(f"{Path(folder) / ACTOR_FILE} does not match the network its config builds "
                         f"(missing {sorted(set(reference) - set(state))[:3]}, "
                         f"unexpected {sorted(set(state) - set(reference))[:3]})")
    model.policy.actor.load_state_dict({key: value.to(reference[key].dtype) for key, value in state.items()},
                                       strict=False)
    return model


def read_provenance(folder: Path) -> dict:
    """An exported actor's ``provenance.json``; {} when it has none."""
    path = Path(folder) / PROVENANCE_FILE
    return json.loads(path.read_text()) if path.is_file() else {}


def open_shipped(folder: Path, arm_collision: bool = True, render_mode: str | None = None,
                 device: str = "cpu") -> tuple[RelmogenEnv, ShippedPolicy]:
    """The environment the policy was trained for (arm collision checking on, as at
    evaluation) and the policy, its network rebuilt from the config and the weights loaded."""
    from relmogen.experiments.environments import env_kwargs

    folder = Path(folder)
    config = read_config(folder / CONFIG_FILE)
    env = RelmogenEnv(**env_kwargs(config, arm_collision), render_mode=render_mode)
    try:
        model = exported_model(folder, config, env, device)
    except ValueError:
        env.close()
        raise
    return env, ShippedPolicy(config, lambda obs: model.predict(obs, deterministic=True)[0], read_provenance(folder))
