"""Scripted demonstrations in the replay buffer (``algo.demo_episodes``; ours, off by default).

The task's oracle (``relmogen/agents/oracles``) drives in-process copies of the training
environment: oracles read privileged simulator state, which subprocess workers do not share.
Each oracle action is a ``subgoal-r`` action; relmogen-r stores it unchanged, relmogen-d
executes and stores the nearest discrete action (``SubgoalDControl.nearest_index``: the cell
holding the oracle's base goal or pixel, the nearest yaw or push bin). The transitions go in
through the algorithm's own ``_store_transition``, as if the policy had acted. relmogen-d keeps
the cell masks it acted under and marks the rows as demonstrations: ``algo.demo_keep`` keeps them
for the whole run, ``algo.demo_margin_weight`` adds DQfD's margin term on them. They are not
counted as environment steps of the policy (``num_timesteps``, the epsilon schedule,
``learning_starts``) nor as training episodes.

``OracleLabels`` (``algo.oracle_labels``) wraps each training environment, in its own worker
process, with the task's oracle; ``RelmogenDQN`` asks it for the oracle's discrete action in the
state the policy is about to act in and stores that as the transition's label.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from rich.console import Console
from rich.progress import Progress
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.dqn import RelmogenDQN, info_masks
from relmogen.agents.oracles import make_policy

SUBGOAL_CONTROLS = ("subgoal-r", "subgoal-d")


def add_demonstrations(model, make_env: Callable, episodes: int, seed: int, quiet: bool = False) -> dict:
    """Run ``episodes`` oracle episodes on ``model.n_envs`` environments made by ``make_env`` and
    add every transition to ``model.replay_buffer``; returns what the demonstrations achieved."""
    inner = DummyVecEnv([make_env] * model.n_envs)
    envs = [env.unwrapped for env in inner.envs]
    venv = model._wrap_env(inner, monitor_wrapper=False)  # observations as the model sees them (images CHW)
    if envs[0].control.name not in SUBGOAL_CONTROLS:
        inner.close()
        raise ValueError(f"demonstrations act through subgoal controls, not {envs[0].control.name!r}")
    oracles = [make_policy("oracle", env) for env in envs]
    saved = {key: getattr(model, key, None) for key in ("_last_obs", "_last_original_obs", "_acting_masks")}
    venv.seed(seed)
    obs, started = venv.reset(), time.time()
    marks = hasattr(model.replay_buffer, "adding_demonstrations")  # relmogen-d's buffer marks their rows
    for oracle in oracles:
        oracle.reset()
    returns, successes, running = [], [], np.zeros(model.n_envs)
    transitions = 0
    try:
        if marks:
            model.replay_buffer.adding_demonstrations = True
        with Progress(disable=quiet, console=Console(stderr=True)) as progress:
            bar = progress.add_task("oracle demonstrations", total=episodes)
            while len(returns) < episodes:
                actions = np.array([_policy_action(env, oracle.act(_single(obs, index)))
                                    for index, (env, oracle) in enumerate(zip(envs, oracles))])
                model._last_obs = obs
                if isinstance(model, RelmogenDQN):  # it stores the masks it acted under
                    model._acting_masks = np.stack([info_masks(env.control.extra_info(), model.q) for env in envs])
                obs, rewards, dones, infos = venv.step(actions)
                model._store_transition(model.replay_buffer, _buffer_action(model, actions), obs, rewards, dones,
                                        infos)
                transitions += len(envs)
                running += rewards
                for index in np.flatnonzero(dones):
                    returns.append(float(running[index]))
                    successes.append(float(infos[index].get("is_success", False)))
                    running[index] = 0.0
                    oracles[index].reset()
                progress.update(bar, completed=min(len(returns), episodes))
    finally:
        if marks:
            model.replay_buffer.adding_demonstrations = False
        for key, value in saved.items():
            setattr(model, key, value)
        venv.close()
    return {"episodes": len(returns), "transitions": transitions, "success_rate": float(np.mean(successes)),
            "mean_return": float(np.mean(returns)), "wall_time_s": round(time.time() - started, 1)}


class OracleLabels(gym.Wrapper):
    """A ``subgoal-d`` environment that also answers ``oracle_label()``: the discrete action its task
    oracle would take in the current state. The oracle follows every episode from its reset, so
    its progress bookkeeping (``attempt``) sees the policy's subgoals as its own."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        control = env.unwrapped.control.name
        if control != "subgoal-d":
            raise ValueError(f"oracle labels are discrete subgoal actions; the control is {control!r}")
        self.oracle = make_policy("oracle", env.unwrapped)
        self.last_obs = None

    def reset(self, **kwargs):
        self.last_obs, info = self.env.reset(**kwargs)
        self.oracle.reset()
        return self.last_obs, info

    def step(self, action):
        self.last_obs, *rest = self.env.step(action)
        return self.last_obs, *rest

    def oracle_label(self) -> int:
        return oracle_choice(self.oracle, self.last_obs)


class OracleAgreement:
    """Wraps a discrete policy ``obs -> action`` (with ``reset``) for one environment and records,
    per subgoal, whether it chose what the task's oracle would have chosen in the same state
    (``matches``). ``relmogen eval`` reports the mean as ``oracle_agreement``."""

    def __init__(self, act, env):
        self.act, self.oracle, self.matches = act, make_policy("oracle", env.unwrapped), []

    def reset(self) -> None:
        self.act.reset()
        self.oracle.reset()

    def __call__(self, obs: dict) -> int:
        label = oracle_choice(self.oracle, obs)
        action = self.act(obs)
        self.matches.append(int(action) == label)
        return action


def oracle_choice(oracle, obs: dict) -> int:
    """The oracle's discrete action in the current state. The environment's random stream is left
    as it was (a stuck oracle draws from it), so asking does not change the episode."""
    rng = oracle.env.np_random.bit_generator
    state = rng.state
    try:
        return int(_policy_action(oracle.env, oracle.act(obs)))
    finally:
        rng.state = state


def _single(obs: dict, index: int) -> dict:
    return {key: value[index] for key, value in obs.items()}


def _policy_action(env, oracle_action: np.ndarray):
    control = env.control
    return control.nearest_index(oracle_action) if control.name == "subgoal-d" else oracle_action


def _buffer_action(model, actions: np.ndarray) -> np.ndarray:
    """What SB3 stores: the action scaled to [-1, 1] for Box spaces, the index for Discrete ones."""
    if isinstance(model.action_space, spaces.Box):
        return model.policy.scale_action(actions)
    return actions
