"""Load a trained policy with the environment settings of its run: ``relmogen.load``.

One loader serves ``relmogen eval`` and ``relmogen.load``: ``load_trained`` takes a run
directory (its ``latest`` or ``best`` checkpoint, or a named checkpoint folder), a checkpoint
folder, or an exported actor's folder (``relmogen export``, e.g. the shipped
``relmogen/policies/PushDoorNav-relmogen-r``). Each carries its run's settings: a run its
``config.yaml``, each checkpoint folder a copy of it (written with the model; a folder copied out
of its run loads on its own), an exported actor the ``config.yaml`` beside ``actor.pt``. The
result, a ``TrainedPolicy``, gives the ``gym.make`` id and keyword arguments of the environment
``relmogen eval`` builds for it (the run's settings, arm collision checking on) and the policy
acting in such an environment (``obs -> action``, deterministic unless asked).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import gymnasium as gym
import torch as th

from relmogen.agents.addons.critic_select import critic_selected
from relmogen.agents.addons.skip_no_ops import sample_after_no_ops
from relmogen.agents.dqn import env_policy
from relmogen.experiments.shipped import CONFIG_FILE, exported_model, is_exported_policy, read_provenance
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.config import TrainConfig, read_config
from relmogen.experiments.checkpoints import (CHECKPOINTS, best_checkpoint, checkpoint_state, latest_checkpoint,
                                              run_config_file)
from relmogen.experiments.environments import env_kwargs
from relmogen.experiments.models import model_class, require_device, resolve_device

CHECKPOINT_CHOICES = ("latest", "best")
MISSING_CHECKPOINT = {
    "latest": "has no checkpoint yet; train it for run.checkpoint_every_episodes episodes first",
    "best": "has no best checkpoint yet (the first periodic evaluation writes it); use --checkpoint latest",
}


def policy_act(model, config: TrainConfig, env: RelmogenEnv, stochastic: bool = False, skip_no_ops: bool = False,
               critic_select: int = 0, seed: int = 0):
    """``obs -> action`` of ``model`` on ``env`` (SGP-D masked to its free base cells, see
    ``env_policy``), with a ``reset`` to call at the start of each episode."""
    if critic_select:
        return critic_selected(model, critic_select, seed)
    if config.algo == "relmogen-d":
        return env_policy(model, env, deterministic=not stochastic, skip_no_ops=skip_no_ops)
    if config.algo == "hrl4in":  # both levels; subgoals held across steps (agents/hrl4in.py)
        return model.evaluation_policy(env, deterministic=not stochastic)
    if skip_no_ops:
        return sample_after_no_ops(model)

    def act(obs):
        return model.predict(obs, deterministic=not stochastic)[0]

    act.reset = lambda: None
    return act


def resetting_each_episode(act, env: gym.Env):
    """``act`` calling its own ``reset`` on the first observation of each episode (``env`` reset,
    not stepped yet), so that a plain Gymnasium loop needs no call of its own."""
    def policy(obs):
        if env.unwrapped.elapsed_steps == 0:
            act.reset()
        return act(obs)

    policy.reset = act.reset
    return policy


@dataclass
class TrainedPolicy:
    """A trained model with the settings of its run (``config``), as ``relmogen.load`` returns it.

    ``checkpoint`` is the checkpoint folder (an exported actor: its folder), ``run_dir`` the run
    its evaluations are written to (None for an exported actor), ``provenance`` an exported
    actor's ``provenance.json``."""

    model: Any
    config: TrainConfig
    checkpoint: Path
    run_dir: Path | None
    checkpoint_name: str | None
    checkpoint_episode: int | None
    provenance: dict = field(default_factory=dict)

    @property
    def env_id(self) -> str:
        return f"relmogen/{self.config.task}-v0"

    @property
    def env_kwargs(self) -> dict:
        """The ``gym.make`` keyword arguments of the environment ``relmogen eval`` builds: the
        run's settings (control, image size, robot, base goal rule, no-op cost, ...), arm
        collision checking on."""
        kwargs = env_kwargs(self.config, arm_collision=True)
        del kwargs["task"]  # in the id
        return kwargs

    def make_env(self, **overrides) -> gym.Env:
        """``gym.make(env_id, **env_kwargs)``, ``overrides`` replacing or adding keyword arguments
        (e.g. ``render_mode="rgb_array"``, ``arm_collision=False``)."""
        return gym.make(self.env_id, **{**self.env_kwargs, **overrides})

    def policy(self, env: gym.Env, deterministic: bool = True) -> Callable[[dict], Any]:
        """``obs -> action`` in ``env`` (SGP-D reads its cell masks and HRL4IN the robot state from
        it), greedy unless ``deterministic=False`` (SGP-D: epsilon-greedy at its final epsilon)."""
        return resetting_each_episode(policy_act(self.model, self.config, env, stochastic=not deterministic), env)


def load_trained(path: Path, checkpoint: str = "latest", device: str = "auto") -> TrainedPolicy:
    """A run directory (its ``checkpoint``, see ``resolve_checkpoint``), a checkpoint folder or
    an exported actor's folder -> its ``TrainedPolicy``."""
    path = Path(path)
    if is_exported_policy(path):
        return load_exported(path, checkpoint, device)
    folder, run_dir = resolve_checkpoint(path, checkpoint)
    model, config = load_checkpoint(folder, run_dir, device)
    return TrainedPolicy(model, config, folder, run_dir, folder.name, checkpoint_state(folder).get("episodes"))


def load_exported(folder: Path, checkpoint: str = "latest", device: str = "auto") -> TrainedPolicy:
    """An exported actor (one model: ``checkpoint`` must stay ``latest``), its network built on
    the spaces of an environment of its settings."""
    if checkpoint != "latest":
        raise ValueError(f"{folder} is an exported actor, one model: it takes no --checkpoint {checkpoint}")
    config = read_config(folder / CONFIG_FILE)
    env = RelmogenEnv(**env_kwargs(config, arm_collision=True))
    try:
        model = exported_model(folder, config, env, resolve_device(require_device(device)))
    finally:
        env.close()
    provenance = read_provenance(folder)
    return TrainedPolicy(model, config, folder, None, provenance.get("checkpoint"), provenance.get("episodes"),
                         provenance)


def resolve_checkpoint(path: Path, checkpoint: str = "latest") -> tuple[Path, Path]:
    """(checkpoint folder, run directory) of ``path``: a checkpoint folder, the run's pointer file
    ``RUN/checkpoints/best`` or ``latest``, or a run directory with ``checkpoint`` one of
    ``CHECKPOINT_CHOICES`` or the path of a checkpoint folder (or the name of one in the run's
    ``checkpoints/``). A checkpoint folder outside its run is its own run directory."""
    path = Path(path)
    if path.is_file() and path.name in CHECKPOINT_CHOICES and path.parent.name == CHECKPOINTS:
        path = _run_checkpoint(path.parent.parent, path.name)  # the folder the pointer names
    if (path / "model.zip").is_file():
        if checkpoint != "latest":
            raise ValueError(f"{path} is a checkpoint folder; give its run directory to choose --checkpoint "
                             f"{checkpoint}")
        return path, checkpoint_run_dir(path)
    run_config_file(path)
    return _run_checkpoint(path, checkpoint), path


def checkpoint_run_dir(folder: Path) -> Path:
    """The run a checkpoint folder sits in, or the folder itself when it was copied out of its run
    with its ``config.yaml``."""
    run_dir = folder.parent.parent
    if not (run_dir / CONFIG_FILE).is_file() and (folder / CONFIG_FILE).is_file():
        return folder
    run_config_file(run_dir)  # neither: the error names the missing run directory
    return run_dir


def _run_checkpoint(run_dir: Path, checkpoint: str) -> Path:
    if checkpoint in CHECKPOINT_CHOICES:
        folder = (latest_checkpoint if checkpoint == "latest" else best_checkpoint)(run_dir)
        missing = MISSING_CHECKPOINT[checkpoint]
    else:
        candidates = [Path(checkpoint), run_dir / CHECKPOINTS / checkpoint]
        folder = next((c for c in candidates if (c / "model.zip").is_file()), None)
        missing = f"has no checkpoint {checkpoint!r}; give latest, best or a folder holding a model.zip"
    if folder is None:
        raise ValueError(f"{run_dir} {missing}")
    return folder


def checkpoint_config_file(folder: Path, run_dir: Path) -> Path:
    """The configuration a checkpoint was trained with: its own copy, or its run's for
    checkpoints written before the copy was kept (the environment settings never change
    within a run)."""
    own = Path(folder) / CONFIG_FILE
    return own if own.is_file() else Path(run_dir) / CONFIG_FILE


def load_checkpoint(folder: Path, run_dir: Path, device: str = "auto"):
    """The model in a checkpoint folder and its config."""
    config = read_config(checkpoint_config_file(folder, run_dir))
    th.set_num_threads(config.run.torch_threads)  # one thread per process unless the config says otherwise
    model = model_class(config).load(Path(folder) / "model.zip", device=resolve_device(require_device(device)))
    return model, config


def load_policy(path: Path, device: str = "auto", checkpoint: str = "latest"):
    """A run directory (its ``checkpoint``, see ``resolve_checkpoint``) or a checkpoint folder ->
    (model, config, run directory)."""
    folder, run_dir = resolve_checkpoint(path, checkpoint)
    return (*load_checkpoint(folder, run_dir, device), run_dir)
