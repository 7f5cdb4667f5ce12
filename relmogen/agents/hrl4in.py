"""HRL4IN (Li et al. 2020, "HRL4IN: Hierarchical RL for Interactive Navigation with Mobile
Manipulators"), the paper's hierarchical baseline, on the joint-velocity environment of ``sac``.

Two levels, both learned, trained together:

* **High level** (every subgoal): from the observation (RGB-D, LiDAR scan, task vector) it chooses
  a subgoal and an embodiment. The action is ``5 + E`` numbers in [-1, 1]: the subgoal offsets
  ``(base dx, base dy, ee dx, ee dy, ee dz)`` in the robot frame at the moment of choice, scaled by
  ``algo.hrl4in_base_range`` (base, m) and ``algo.hrl4in_ee_range`` (end effector, m, relative to
  its current position), and, with E > 1 embodiments, one score per embodiment in
  ``algo.hrl4in_embodiments`` (``base``, ``arm``, ``both``) of which the largest is chosen. The
  embodiment sets two masks (``EMBODIMENT_MASKS``): the subgoal mask (``base``: base x, y;
  ``arm``: end-effector x, y, z; ``both``: all five) and the action mask over the joint
  velocities (``base``: the 2 wheels; ``arm``: torso and arm, Fetch's 8; ``both``: all). Its reward
  is the task's extrinsic reward summed over the subgoal's steps; its transition ends when the
  subgoal does, and its ``done`` is the episode's termination (a time-limit truncation
  bootstraps).
* **Low level** (every 0.1 s step): the 10 normalised joint velocities of the ``joint`` control
  (``relmogen.envs.controls``). It sees the observation with the task vector extended by the
  remaining subgoal (the world-frame target minus the current state, rotated into the current
  robot frame, masked), the subgoal mask and the action mask. The executed command is its action
  times the action mask, so masked joints get velocity 0 (``masked_command``). A subgoal ends
  when it is achieved (every masked-in component within ``algo.hrl4in_tolerance`` m), after
  ``algo.hrl4in_k`` steps, or with the episode; the low level's transition is terminal then (as
  in HRL4IN, which cut its PPO returns at every subgoal end). Episodes end on collision exactly as
  for ``sac`` and ``oac``: it is the same environment.

Intrinsic reward of the low level, per step (``intrinsic_reward``), with ``d`` the norm of the
masked remaining subgoal before (``d0``) and after (``d1``) the step::

    r = progress_scale * (d0 - d1)          # HRL4IN's potential-based term (its "intrinsic reward scaling")
        - distance_weight * d1              # negative distance to the subgoal
        + success_bonus * [subgoal achieved]
        - mask_penalty * sum((a * (1 - action_mask))^2)   # using masked parts (raw action, before masking)
        + extrinsic_weight * r_task

(``algo.hrl4in_progress_scale`` etc.). The replay stores the raw action, so the critic can learn
the mask penalty.

What the original did, from its released code (github.com/ChengshuLi/HRL4IN,
``train_hrl_relmogen.py`` and ``run_train_relmogen.sh``, the script of the ReLMoGen comparison)
and where this departs:

* **Both levels were PPO** (clip 0.1, GAE, 9 parallel environments x 256 steps per update,
  recurrent policies, entropy 0.01, lr 1e-4 low / 1e-5 high, gamma 0.99 at both levels). Here both
  are SB3's SAC (``SharedEncoderSAC``, the SGP-R encoder of ``sac``/``oac``) with their own replay
  buffers, trained by our collection loop: **off-policy replay is what a 2-core CPU can afford
  (PPO wants thousands of fresh on-policy steps per update) and it keeps the baseline's learner
  identical to the ``sac`` baseline's, so the comparison isolates the hierarchy.** No recurrence.
* **The embodiment selector** was a categorical head of the PPO policy; here it is the argmax of
  E continuous scores (as SGP-R selects base or arm), so SAC can train it.
* **Subgoal space**: the original's subgoal was an offset of the end-effector's world position
  (its "arm_world"; the base-only mask kept x, y), in a ±2 m box. Here base and end effector have
  their own components (the task description's "base position and end-effector position"); the
  ranges are ours (presets).
* **Embodiments**: the ReLMoGen run offered {base, arm}; the Gibson experiments {base, base+arm}
  and the grid world {base, arm, both}. The presets offer all three.
* **Intrinsic reward**: the released code used only the potential term (scaling 30 in the ReLMoGen
  run), a subgoal-achieved bonus (0 there) and no extrinsic reward for the low level; it zeroed
  masked actions and had no mask penalty. The distance and mask-penalty terms are additions,
  off (0) unless a preset sets them.
* **Subgoal tolerance**: the original required each masked component within 0.05 m; ``cpu``
  uses 0.1 m (a presets' note says why). ``k`` (its ``time_scale``) was 30 in the ReLMoGen run.
* **Not ported**: its subgoal-failed penalty for the high level (0 in the ReLMoGen run), action
  hindsight (off there), and learning-rate/clip decay.

Checkpoints: ``model.zip`` holds both SB3 models (``high.zip``, ``low.zip``) and the loop's state
(``hrl4in.json``); the replay file holds both buffers. Training statistics go to TensorBoard as
``losses/{high,low}_*`` and ``losses/subgoal_*``.
"""

from __future__ import annotations

import io
import json
import zipfile
from collections import deque
from dataclasses import asdict, dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.logger import Logger
from stable_baselines3.common.save_util import load_from_pkl, save_to_pkl

from relmogen.agents.networks import SGPREncoder
from relmogen.agents.replay import CompactDictReplayBuffer
from relmogen.agents.sac import SharedEncoderSAC
from relmogen.envs.hrl4in_wrapper import ROBOT_STATE_KEY, robot_state

EMBODIMENTS = ("base", "arm", "both")
SUBGOAL_DIM = 5  # base dx, dy; end-effector dx, dy, dz
N_JOINTS = 10  # Fetch: 2 wheels, torso, 7 arm joints (the joint control's order: wheels first)
N_WHEELS = 2


def embodiment_masks(embodiment: str, n_joints: int = N_JOINTS) -> tuple[np.ndarray, np.ndarray]:
    """(subgoal mask over the SUBGOAL_DIM components, action mask over the ``n_joints`` velocities)."""
    wheels = np.r_[np.ones(N_WHEELS), np.zeros(n_joints - N_WHEELS)].astype(np.float32)
    return {
        "base": (np.array([1, 1, 0, 0, 0], np.float32), wheels),
        "arm": (np.array([0, 0, 1, 1, 1], np.float32), 1.0 - wheels),
        "both": (np.ones(SUBGOAL_DIM, np.float32), np.ones(n_joints, np.float32)),
    }[embodiment]


EMBODIMENT_MASKS = {name: embodiment_masks(name) for name in EMBODIMENTS}  # Fetch's
POLICY_KEYS = ("rgb", "depth", "scan", "task_obs")
STATS_WINDOW = 100  # subgoals the logged subgoal statistics are averaged over


@dataclass
class HRL4INSettings:
    k: int = 30
    embodiments: tuple[str, ...] = EMBODIMENTS
    base_range: float = 1.0
    ee_range: float = 0.5
    tolerance: float = 0.1
    progress_scale: float = 30.0
    distance_weight: float = 0.0
    success_bonus: float = 0.0
    mask_penalty: float = 0.0
    extrinsic_weight: float = 0.0
    n_joints: int = N_JOINTS  # the joint control's action size (the environment's)

    def __post_init__(self) -> None:
        self.embodiments = tuple(self.embodiments)
        unknown = [name for name in self.embodiments if name not in EMBODIMENTS]
        if unknown or not self.embodiments or len(set(self.embodiments)) < len(self.embodiments):
            raise ValueError(f"hrl4in embodiments must be distinct names of {', '.join(EMBODIMENTS)}; "
                             f"got {list(self.embodiments)}")

    @property
    def selector_dim(self) -> int:
        return len(self.embodiments) if len(self.embodiments) > 1 else 0

    @property
    def high_action_dim(self) -> int:
        return SUBGOAL_DIM + self.selector_dim

    @property
    def subgoal_scale(self) -> np.ndarray:
        return np.array([self.base_range] * 2 + [self.ee_range] * 3, np.float32)


def _rotation(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s], [s, c]])


@dataclass
class Subgoal:
    """One high-level decision: world-frame targets (base x, y; end effector x, y, z), its masks,
    and the low-level steps spent on it."""

    target: np.ndarray
    subgoal_mask: np.ndarray
    action_mask: np.ndarray
    embodiment: str
    steps: int = 0

    @classmethod
    def from_action(cls, action: np.ndarray, state: np.ndarray, settings: HRL4INSettings) -> Subgoal:
        """Decode a high-level action in [-1, 1] at robot state ``state`` (``robot_state``)."""
        action = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        index = int(np.argmax(action[SUBGOAL_DIM:])) if settings.selector_dim else 0
        embodiment = settings.embodiments[index]
        subgoal_mask, action_mask = embodiment_masks(embodiment, settings.n_joints)
        offsets = action[:SUBGOAL_DIM] * settings.subgoal_scale * subgoal_mask
        rotation = _rotation(float(state[2]))
        target = np.concatenate([state[:2] + rotation @ offsets[:2],
                                 state[3:5] + rotation @ offsets[2:4], [state[5] + offsets[4]]])
        return cls(target, subgoal_mask.copy(), action_mask.copy(), embodiment)

    def remaining(self, state: np.ndarray) -> np.ndarray:
        """Target minus ``state``, x-y parts rotated into the current robot frame, masked."""
        diff = self.target - np.concatenate([state[:2], state[3:6]])
        inverse = _rotation(float(state[2])).T
        local = np.concatenate([inverse @ diff[:2], inverse @ diff[2:4], diff[4:]])
        return (local * self.subgoal_mask).astype(np.float32)

    def distance(self, state: np.ndarray) -> float:
        return float(np.linalg.norm(self.remaining(state)))

    def achieved(self, state: np.ndarray, tolerance: float) -> bool:
        return bool(np.all(np.abs(self.remaining(state)) < tolerance))


def masked_command(action: np.ndarray, action_mask: np.ndarray) -> np.ndarray:
    """The joint velocities executed: the low level's action with the masked joints at 0."""
    return (np.clip(action, -1.0, 1.0) * action_mask).astype(np.float32)


def intrinsic_reward(subgoal: Subgoal, before: np.ndarray, after: np.ndarray, action: np.ndarray,
                     extrinsic: float, settings: HRL4INSettings) -> tuple[float, bool, dict[str, float]]:
    """The low level's reward for one step from robot state ``before`` to ``after`` with raw action
    ``action`` (see the module doc); also whether the subgoal is achieved and the terms."""
    d0, d1 = subgoal.distance(before), subgoal.distance(after)
    achieved = subgoal.achieved(after, settings.tolerance)
    terms = {
        "progress": settings.progress_scale * (d0 - d1),
        "distance": -settings.distance_weight * d1,
        "success": settings.success_bonus * float(achieved),
        "mask": -settings.mask_penalty * float(np.sum((np.asarray(action) * (1.0 - subgoal.action_mask)) ** 2)),
        "extrinsic": settings.extrinsic_weight * float(extrinsic),
    }
    return float(sum(terms.values())), achieved, terms


# ------------------------------------------------------------------------- observations
def policy_observation(obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The policy keys of a batched observation, RGB channels-first (as SB3's ``VecTransposeImage``
    gives the other SAC models, so the replay layout is the same)."""
    out = {key: np.asarray(obs[key]) for key in POLICY_KEYS}
    if out["rgb"].shape[-1] == 3:
        out["rgb"] = np.ascontiguousarray(np.moveaxis(out["rgb"], -1, 1))
    return out


def low_observation(obs: dict[str, np.ndarray], subgoals: list[Subgoal], states: np.ndarray) -> dict[str, np.ndarray]:
    """The low level's batched observation: ``task_obs`` extended by the remaining subgoal, the
    subgoal mask and the action mask of each row's subgoal."""
    out = policy_observation(obs)
    extra = np.stack([np.concatenate([g.remaining(s), g.subgoal_mask, g.action_mask])
                      for g, s in zip(subgoals, states)]).astype(np.float32)
    out["task_obs"] = np.concatenate([out["task_obs"].astype(np.float32), extra], axis=1)
    return out


def _row(obs: dict[str, np.ndarray], index: int) -> dict[str, np.ndarray]:
    return {key: value[index:index + 1].copy() for key, value in obs.items()}


def _terminal_row(infos: list[dict], new_obs: dict, index: int, done: bool) -> dict[str, np.ndarray]:
    """Row ``index`` of the observation that ended the step: the terminal one after an auto-reset."""
    if done and "terminal_observation" in infos[index]:
        return {key: np.asarray(value)[None] for key, value in infos[index]["terminal_observation"].items()}
    return _row(new_obs, index)


class _SpacesEnv(gym.Env):
    """Carries a pair of spaces so SB3 can build a model; never stepped."""

    def __init__(self, observation_space: spaces.Space, action_space: spaces.Space):
        self.observation_space, self.action_space = observation_space, action_space

    def reset(self, *, seed=None, options=None):
        return self.observation_space.sample(), {}

    def step(self, action):
        raise RuntimeError("a spaces-only environment is never stepped")


def level_spaces(observation_space: spaces.Dict, settings: HRL4INSettings) -> tuple[spaces.Dict, spaces.Dict]:
    """(high, low) observation spaces from the training environment's (``robot_state`` dropped)."""
    high = spaces.Dict({key: observation_space[key] for key in POLICY_KEYS})
    extra = SUBGOAL_DIM + SUBGOAL_DIM + settings.n_joints  # remaining subgoal, subgoal mask, action mask
    task = observation_space["task_obs"]
    low = spaces.Dict({**high.spaces, "task_obs": spaces.Box(-np.inf, np.inf, (task.shape[0] + extra,),
                                                                 np.float32)})
    return high, low


# ----------------------------------------------------------------------------- model
LOOP_KEYS = ("learning_starts", "train_freq", "gradient_steps", "batch_size", "high_learning_starts",
             "high_gradient_steps", "high_batch_size")


@dataclass
class LoopParams:
    learning_starts: int = 1000  # low-level transitions of uniform random actions first
    train_freq: int = 1  # low-level gradient steps every this many vectorised steps
    gradient_steps: int = 1
    batch_size: int = 256
    high_learning_starts: int = 50  # high-level transitions of uniform random subgoals first
    high_gradient_steps: int = 1  # per high-level transition
    high_batch_size: int = 256


@dataclass
class _EnvSlot:
    """Bookkeeping of one training environment's current subgoal."""

    subgoal: Subgoal | None = None
    start_obs: dict | None = None
    action: np.ndarray | None = None
    extrinsic: float = 0.0


class HRL4IN:
    """Two ``SharedEncoderSAC`` models and the collection loop between them (module doc). It offers
    what ``relmogen.experiments.train`` uses of an SB3 model: ``learn`` with a callback, ``save`` /
    ``load``, ``save_replay_buffer`` / ``load_replay_buffer``, ``replay_buffer`` (the low
    level's), ``num_timesteps``, ``logger`` and ``get_env``."""

    def __init__(self, high: SharedEncoderSAC, low: SharedEncoderSAC, settings: HRL4INSettings, loop: LoopParams,
                 env=None, seed: int = 0):
        self.high, self.low, self.settings, self.loop = high, low, settings, loop
        self.env, self.seed = env, seed
        self.num_timesteps, self.high_transitions = 0, 0
        self.logger = Logger(None, [])
        for model in (high, low):
            model.set_logger(Logger(None, []))
        self.rng = np.random.default_rng(seed)
        self.stats: deque = deque(maxlen=STATS_WINDOW)  # (achieved, steps, embodiment) per ended subgoal

    # -------------------------------------------------------------- SB3-like surface
    @property
    def replay_buffer(self):
        return self.low.replay_buffer

    @property
    def device(self):
        return self.low.device

    @property
    def _n_updates(self) -> int:
        """Gradient steps of both levels, as SB3 models count theirs."""
        return self.high._n_updates + self.low._n_updates

    def get_env(self):
        return self.env

    def set_env(self, env) -> None:
        self.env = env

    def choose_subgoal(self, obs_row: dict, state: np.ndarray, deterministic: bool, explore_randomly: bool):
        """(subgoal, high-level action) for one environment's policy-observation row."""
        if explore_randomly:
            action = self.rng.uniform(-1.0, 1.0, self.settings.high_action_dim).astype(np.float32)
        else:
            action = self.high.predict(obs_row, deterministic=deterministic)[0][0]
        return Subgoal.from_action(action, state, self.settings), np.asarray(action, np.float32)

    def evaluation_policy(self, env, deterministic: bool = True) -> HRL4INPolicy:
        return HRL4INPolicy(self, env, deterministic)

    # --------------------------------------------------------------------- training
    def learn(self, total_timesteps: int, callback=None, reset_num_timesteps: bool = True, progress_bar: bool = False):
        if reset_num_timesteps:
            self.num_timesteps = 0
        env, start = self.env, self.num_timesteps
        n_envs = env.num_envs
        if callback is not None:
            callback.init_callback(self)
            callback.on_training_start(locals(), globals())
        obs = env.reset()
        slots = [_EnvSlot() for _ in range(n_envs)]
        vec_steps = 0
        try:
            while self.num_timesteps - start < total_timesteps:
                states = np.asarray(obs[ROBOT_STATE_KEY], dtype=np.float64)
                policy_obs = policy_observation(obs)
                for index, slot in enumerate(slots):
                    if slot.subgoal is None:
                        row = _row(policy_obs, index)
                        slot.subgoal, slot.action = self.choose_subgoal(
                            row, states[index], deterministic=False,
                            explore_randomly=self.high_transitions < self.loop.high_learning_starts)
                        slot.start_obs, slot.extrinsic = row, 0.0
                subgoals = [slot.subgoal for slot in slots]
                low_obs = low_observation(obs, subgoals, states)
                if self.num_timesteps < self.loop.learning_starts:
                    actions = self.rng.uniform(-1.0, 1.0, (n_envs, self.settings.n_joints)).astype(np.float32)
                else:
                    actions = self.low.predict(low_obs, deterministic=False)[0]
                commands = np.stack([masked_command(a, g.action_mask) for a, g in zip(actions, subgoals)])
                new_obs, rewards, dones, infos = env.step(commands)
                self.num_timesteps += n_envs
                vec_steps += 1
                for index, slot in enumerate(slots):
                    self._store_step(slot, index, obs, low_obs, new_obs, actions[index], float(rewards[index]),
                                     bool(dones[index]), infos)
                obs = new_obs
                if self.num_timesteps >= self.loop.learning_starts and vec_steps % self.loop.train_freq == 0:
                    self._train(self.low, "low", self.loop.gradient_steps, self.loop.batch_size)
                if callback is not None:
                    callback.update_locals({"infos": infos, "dones": dones})
                    if not callback.on_step():
                        break
        finally:
            if callback is not None:
                callback.on_training_end()
        return self

    def _store_step(self, slot: _EnvSlot, index: int, obs: dict, low_obs: dict, new_obs: dict, action: np.ndarray,
                    reward: float, done: bool, infos: list[dict]) -> None:
        info = infos[index]
        before = np.asarray(obs[ROBOT_STATE_KEY][index], dtype=np.float64)
        final = _terminal_row(infos, new_obs, index, done)
        after = np.asarray(final[ROBOT_STATE_KEY][0], dtype=np.float64)
        subgoal = slot.subgoal
        r_int, achieved, _ = intrinsic_reward(subgoal, before, after, action, reward, self.settings)
        subgoal.steps += 1
        slot.extrinsic += reward
        ended = achieved or subgoal.steps >= self.settings.k or done
        next_low = low_observation(final, [subgoal], after[None])
        self.low.replay_buffer.add(_row(low_obs, index), next_low, action[None], np.array([r_int]),
                                   np.array([ended]), [{}])
        if not ended:
            return
        truncated = bool(info.get("TimeLimit.truncated", False))
        self.high.replay_buffer.add(slot.start_obs, policy_observation(final), slot.action[None],
                                    np.array([slot.extrinsic]), np.array([done]),
                                    [{"TimeLimit.truncated": truncated}])
        self.high_transitions += 1
        self.stats.append((achieved, subgoal.steps, subgoal.embodiment))
        slot.subgoal = None
        if self.high_transitions >= self.loop.high_learning_starts:
            self._train(self.high, "high", self.loop.high_gradient_steps, self.loop.high_batch_size)
        self._record_subgoal_stats()

    def _train(self, model: SharedEncoderSAC, prefix: str, gradient_steps: int, batch_size: int) -> None:
        if model.replay_buffer.size() == 0:
            return
        model.train(gradient_steps=gradient_steps, batch_size=batch_size)
        for key, value in model.logger.name_to_value.items():
            if key.startswith("train/") and key != "train/n_updates":
                self.logger.record(f"train/{prefix}_{key.split('/', 1)[1]}", value)

    def _record_subgoal_stats(self) -> None:
        achieved, steps, used = zip(*self.stats)
        self.logger.record("train/subgoal_achieved_rate", float(np.mean(achieved)))
        self.logger.record("train/subgoal_length", float(np.mean(steps)))
        for name in self.settings.embodiments:
            self.logger.record(f"train/subgoal_{name}_fraction", float(np.mean([u == name for u in used])))

    # ------------------------------------------------------------------ persistence
    def _state(self) -> dict[str, Any]:
        return {"settings": asdict(self.settings), "loop": asdict(self.loop), "num_timesteps": self.num_timesteps,
                "high_transitions": self.high_transitions, "seed": self.seed}

    def save(self, path) -> None:
        with zipfile.ZipFile(path, "w") as archive:
            for name, model in (("high", self.high), ("low", self.low)):
                buffer = io.BytesIO()
                model.save(buffer)
                archive.writestr(f"{name}.zip", buffer.getvalue())
            archive.writestr("hrl4in.json", json.dumps(self._state()))

    @classmethod
    def load(cls, path, env=None, device: str | th.device = "auto", **kwargs: Any) -> HRL4IN:
        """A saved model; ``kwargs`` (the resumable ``algo.`` keys a resume changed) apply to the
        low level and, where they are ``LOOP_KEYS``, to the loop."""
        with zipfile.ZipFile(path) as archive:
            state = json.loads(archive.read("hrl4in.json"))
            high = SharedEncoderSAC.load(io.BytesIO(archive.read("high.zip")), device=device)
            low = SharedEncoderSAC.load(io.BytesIO(archive.read("low.zip")), device=device, **kwargs)
        settings = HRL4INSettings(**state["settings"])
        loop = LoopParams(**{**state["loop"], **{key: kwargs[key] for key in LOOP_KEYS if key in kwargs}})
        model = cls(high, low, settings, loop, env=env, seed=state["seed"])
        model.num_timesteps, model.high_transitions = state["num_timesteps"], state["high_transitions"]
        return model

    def save_replay_buffer(self, path) -> None:
        save_to_pkl(path, {"high": self.high.replay_buffer, "low": self.low.replay_buffer})

    def load_replay_buffer(self, path) -> None:
        buffers = load_from_pkl(path)
        self.high.replay_buffer, self.low.replay_buffer = buffers["high"], buffers["low"]
        for model in (self.high, self.low):
            model.replay_buffer.device = model.device


class HRL4INPolicy:
    """Both levels acting in one in-process ``RelmogenEnv`` (evaluation): call it with each
    observation, ``reset`` after each ``env.reset``. The robot state is read from ``env``."""

    def __init__(self, model: HRL4IN, env, deterministic: bool = True):
        self.model, self.env, self.deterministic = model, env, deterministic
        self.subgoal: Subgoal | None = None
        self.embodiments: list[str] = []  # the embodiment of every subgoal chosen (diagnostics)

    def reset(self) -> None:
        self.subgoal = None

    def __call__(self, obs: dict) -> np.ndarray:
        state = robot_state(self.env).astype(np.float64)
        settings = self.model.settings
        if self.subgoal is not None and (self.subgoal.steps >= settings.k
                                         or self.subgoal.achieved(state, settings.tolerance)):
            self.subgoal = None
        batched = {key: np.asarray(value)[None] for key, value in obs.items()}
        if self.subgoal is None:
            self.subgoal, _ = self.model.choose_subgoal(policy_observation(batched), state, self.deterministic,
                                                        explore_randomly=False)
            self.embodiments.append(self.subgoal.embodiment)
        action = self.model.low.predict(low_observation(batched, [self.subgoal], state[None]),
                                        deterministic=self.deterministic)[0][0]
        self.subgoal.steps += 1
        return masked_command(action, self.subgoal.action_mask)


# ------------------------------------------------------------------------------ build
def settings_from_params(params, n_joints: int = N_JOINTS) -> HRL4INSettings:
    return HRL4INSettings(k=params.hrl4in_k, n_joints=n_joints, embodiments=tuple(params.hrl4in_embodiments),
                          base_range=params.hrl4in_base_range, ee_range=params.hrl4in_ee_range,
                          tolerance=params.hrl4in_tolerance, progress_scale=params.hrl4in_progress_scale,
                          distance_weight=params.hrl4in_distance_weight, success_bonus=params.hrl4in_success_bonus,
                          mask_penalty=params.hrl4in_mask_penalty, extrinsic_weight=params.hrl4in_extrinsic_weight)


def build_hrl4in(config, env, device: str) -> HRL4IN:
    """The two levels for ``config`` (a ``TrainConfig`` with ``algo: hrl4in``) on the training
    environments ``env`` (observations with ``robot_state``: ``RobotStateObservation``)."""
    params = config.algo_params
    settings = settings_from_params(params, n_joints=env.action_space.shape[0])
    if ROBOT_STATE_KEY not in env.observation_space.spaces:
        raise ValueError("hrl4in trains on environments wrapped in RobotStateObservation (robot_state missing)")
    high_space, low_space = level_spaces(env.observation_space, settings)
    policy_kwargs = dict(features_extractor_class=SGPREncoder, normalize_images=False, net_arch=params.net_arch,
                         features_extractor_kwargs={"image_shift": params.image_shift},
                         **({"critic_layer_norm": True} if params.critic_layer_norm else {}))
    common = dict(tau=params.tau, ent_coef=f"auto_{params.ent_coef_init}", ent_coef_min=params.ent_coef_min,
                  policy_kwargs=policy_kwargs, replay_buffer_class=CompactDictReplayBuffer, device=device, verbose=0)
    high_batch = params.hrl4in_high_batch_size or params.batch_size
    high = SharedEncoderSAC(
        env=_SpacesEnv(high_space, spaces.Box(-1.0, 1.0, (settings.high_action_dim,), np.float32)),
        learning_rate=params.hrl4in_high_learning_rate or params.learning_rate,
        buffer_size=params.hrl4in_high_buffer_size, batch_size=high_batch, gamma=params.hrl4in_high_gamma,
        learning_starts=params.hrl4in_high_learning_starts, seed=config.seed, **common)
    low = SharedEncoderSAC(
        env=_SpacesEnv(low_space, env.action_space), learning_rate=params.learning_rate,
        buffer_size=params.buffer_size, batch_size=params.batch_size, gamma=params.gamma,
        learning_starts=params.learning_starts, train_freq=params.train_freq, gradient_steps=params.gradient_steps,
        target_entropy="auto" if params.target_entropy is None else params.target_entropy,
        seed=config.seed + 1, **common)
    loop = LoopParams(learning_starts=params.learning_starts, train_freq=params.train_freq,
                      gradient_steps=params.gradient_steps, batch_size=params.batch_size,
                      high_learning_starts=params.hrl4in_high_learning_starts,
                      high_gradient_steps=params.gradient_steps, high_batch_size=high_batch)
    return HRL4IN(high, low, settings, loop, env=env, seed=config.seed)
