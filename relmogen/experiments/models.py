"""The model factory of ``relmogen train``: the SB3 model of a run's algorithm and settings, and
the device it runs on."""

from __future__ import annotations

import torch as th

from relmogen.agents.dqn import RelmogenDQN
from relmogen.agents.hrl4in import HRL4IN, build_hrl4in
from relmogen.agents.networks import SGPREncoder
from relmogen.agents.replay import CompactDictReplayBuffer
from relmogen.agents.sac import OAC, SharedEncoderSAC
from relmogen.experiments.config import AlgoConfig, TrainConfig


def resolve_device(device: str) -> str:
    if device == "auto":
        return "cuda" if th.cuda.is_available() else "cpu"
    return device


def require_device(device: str) -> str:
    """``device`` when this machine has it: ``auto``, ``cpu``, ``cuda[:N]`` with CUDA, ``mps`` with
    MPS. An accelerator that is missing is an error, not a silent run on the CPU."""
    if device == "auto":
        return device
    try:
        kind = th.device(device).type
    except RuntimeError as error:
        raise ValueError(f"unknown device {device!r}; use auto, cpu or cuda") from error
    available = {"cpu": True, "cuda": th.cuda.is_available(), "mps": th.backends.mps.is_available()}
    if not available.get(kind, False):
        raise ValueError(f"device {device!r} is not available on this machine; use --device cpu or --device auto")
    return device


def build_model(config: TrainConfig, env):
    th.set_num_threads(config.run.torch_threads)
    if config.algo == "relmogen-d":
        return build_dqn(config, env)
    if config.algo == "hrl4in":  # two SAC levels and their own collection loop (agents/hrl4in.py)
        return build_hrl4in(config, env, resolve_device(config.device))
    params = config.algo_params
    # fused Adam: one kernel per step instead of one per tensor (updates 72 -> 69 ms of CPU, batch 64)
    policy_kwargs = dict(net_arch=params.net_arch, optimizer_kwargs={"fused": True})
    if params.critic_layer_norm:  # a policy kwarg, so that a saved model reloads it
        policy_kwargs.update(critic_layer_norm=True)
    if config.env.obs_mode == "rgbd":  # state: SB3's CombinedExtractor flattens the vector
        policy_kwargs.update(features_extractor_class=SGPREncoder, normalize_images=False,
                             features_extractor_kwargs={"image_shift": params.image_shift,
                                                        "image_encoder": params.image_encoder})
    common = dict(env=env, learning_rate=params.learning_rate, buffer_size=params.buffer_size,
                  batch_size=params.batch_size, tau=params.tau, gamma=params.gamma,
                  learning_starts=params.learning_starts, train_freq=params.train_freq,
                  gradient_steps=params.gradient_steps, ent_coef=f"auto_{params.ent_coef_init}",
                  ent_coef_min=params.ent_coef_min,
                  target_entropy="auto" if params.target_entropy is None else params.target_entropy,
                  policy_kwargs=policy_kwargs, replay_buffer_class=CompactDictReplayBuffer, seed=config.seed,
                  device=resolve_device(config.device), verbose=0)
    if config.algo == "oac":
        return OAC(beta_ub=params.beta_ub, delta=params.delta, **common)
    return SharedEncoderSAC(**common)


def build_dqn(config: TrainConfig, env) -> RelmogenDQN:
    """relmogen-d's model: every key of its own (``RelmogenDConfig`` beyond ``AlgoConfig``) that is
    set goes to ``RelmogenDQN``, the ``qmap_*`` ones to its Q-map network, ``demo_keep`` to its replay."""
    from relmogen.tasks import task_class

    params = config.algo_params
    own = {key: value for key, value in params.model_dump(exclude=set(AlgoConfig.model_fields)).items()
           if value is not None}
    policy_kwargs = {key.removeprefix("qmap_"): own.pop(key) for key in list(own) if key.startswith("qmap_")}
    keep_demonstrations = own.pop("demo_keep")
    return RelmogenDQN(env=env, learning_rate=params.learning_rate, buffer_size=params.buffer_size,
                       replay_buffer_kwargs={"keep_demonstrations": keep_demonstrations},
                       batch_size=params.batch_size, gamma=params.gamma, learning_starts=params.learning_starts,
                       train_freq=params.train_freq, gradient_steps=params.gradient_steps, tau=params.tau,
                       subgoal_parts=task_class(config.task).subgoal_parts, policy_kwargs=policy_kwargs,
                       seed=config.seed, device=resolve_device(config.device), verbose=0, **own)


def model_class(config: TrainConfig):
    return {"oac": OAC, "relmogen-d": RelmogenDQN, "hrl4in": HRL4IN}.get(config.algo, SharedEncoderSAC)
