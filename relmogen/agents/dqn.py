"""SGP-D: Double DQN over dense per-pixel Q maps (``relmogen-d``; facts sheet sections 5-6).

``RelmogenDQN`` is SB3's ``DQN`` with
  * ``QMapDQNPolicy``: online and target nets are ``QMapNetwork`` (two conv branches, two
    deconvolutions to (L + K) Q x Q maps; ``relmogen/agents/qmap_network.py``);
  * Double DQN targets: the online net picks the next action, the target net values it;
    Huber loss, gradient-norm clip 10, hard target update every 1024 steps (``tau = 1``),
    epsilon from 0.8 to 0.04 (the paper's hyperparameters are the defaults), linearly over
    ``exploration_steps`` environment steps when given;
  * action masking: base actions whose cell is occupied (``info["base_mask"]`` False) are
    never chosen, neither greedily (Q set to -inf) nor at random (uniform over the allowed
    actions), nor as the online argmax of the Double DQN target (the replay buffer keeps the
    next state's masks); the original masked these. With ``mask_arm`` (default; our
    addition) arm actions whose pixel has no depth or lies beyond the arm's reach
    (``info["arm_mask"]`` False, a push that never finds a plan) are masked the same way.
    Actions of a part the task does not use (``subgoal_parts``) are masked too.

Masks are (N, 2, Q, Q) bool arrays, channel 0 base cells and channel 1 arm cells. They are
not part of the observation: ``CellMaskTracker``, a ``VecEnvWrapper`` that ``RelmogenDQN``
puts around every environment it is given (``_wrap_env``), records the latest masks of each
sub-environment from the step infos, or from the VecEnv's ``reset_infos`` after a
(auto-)reset. ``predict(obs, masks=...)`` takes masks explicitly (without them every action
of the used parts is allowed); ``env_policy(model, env)`` reads them from a single
environment for evaluation.

``QMapReplayBuffer`` stores depth as float16 (<= 3 m: step <= 2 mm) and the next state's
masks; SB3's ``optimize_memory_usage`` is not available for Dict observations.

Conservative term (``conservative_weight`` > 0; our addition, off by default): adds
``weight * (logsumexp_a Q(s, a) - Q(s, a_taken))`` over the allowed actions of the stored
state to the Huber loss (the discrete CQL(H) regulariser of Kumar et al., 2020). With ~3,000
arm actions of which a replay has tried few, Double DQN targets still bootstrap from the
untried ones; the term pushes those down and the taken ones up. The buffer therefore keeps
each transition's own masks too (the masks the action was chosen under). On ButtonDoorNav it
lowered the button further (``results/sgpd-cql``).

Demonstration margin (``demo_margin_weight`` > 0; ours, off by default): DQfD's supervised
large-margin term (Hester et al., 2018) on the batch's demonstration rows (``algo.demo_episodes``,
``QMapReplayBuffer.demo``) makes the demonstrated action's Q exceed every other allowed action's
by ``DQFD_MARGIN``: ``max_a [Q(s, a) + 0.8 [a != a_E]] - Q(s, a_E)``. The ``cpu`` preset's
16 x 16 maps hold 3,072 arm actions, and a demonstrated press is one of them: the TD loss alone
left the few demonstrated presses below their untried neighbours (``results/sgpd-demos``).

Oracle labels (``oracle_labels``; ours, off by default, DAgger's idea with DQfD's loss): before
each training step every environment is asked for its task oracle's choice in its current state
(``env_method("oracle_label")``, answered by ``relmogen.agents.demonstrations.OracleLabels``).
The policy still acts; the label goes into the replay with the transition and the margin term
applies to it as to a demonstration's action. Demonstrations show the oracle's own states only;
the labels cover the states the policy reaches by its own mistakes. ``rollout/oracle_agreement``
logs how often the policy chose the label (last 1,000 transitions, exploration included).

N-step returns (``n_step_returns`` = n > 1; off by default, DQfD and Rainbow use them): the
target of a stored transition sums the discounted rewards of up to n consecutive stored steps of
its environment and bootstraps with gamma^k from the k-th next state (k <= n, fewer at an episode
end, at the newest row and where kept demonstration rows border policy rows). A +10 success
reaches the press that made it possible in one update instead of n; and a subgoal that changes
nothing, repeated (its next state is its own state), loses value gamma^n per target update
instead of gamma. ``QMapReplayBuffer`` computes the windows at sampling time from the rows it
already stores, as SB3's ``NStepReplayBuffer`` does (which does not take Dict observations).
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any, NamedTuple

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import DQN
from stable_baselines3.common.policies import BasePolicy
from stable_baselines3.common.type_aliases import TensorDict
from stable_baselines3.common.vec_env import VecEnv, VecEnvWrapper, is_vecenv_wrapped
from stable_baselines3.dqn.policies import DQNPolicy
from torch.nn import functional as F

from relmogen.agents.qmap_network import NUM_MAPS, QMapNetwork
from relmogen.agents.replay import CompactDictReplayBuffer, with_full_capacity
from relmogen.envs.relmogen_env import VIEW_KEYS, view_unchanged
from relmogen.envs.subgoal_controls import PUSH_BINS, YAW_BINS

ALL_PARTS = ("base", "arm")
DQFD_MARGIN = 0.8  # the expert margin of DQfD (Hester et al., 2018)
LABEL_AGREEMENT_WINDOW = 1000  # policy transitions behind ``rollout/oracle_agreement``
ORACLE_LABEL_METHOD = "oracle_label"  # what ``oracle_labels`` calls on every training environment
MASK_KEYS = ("base_mask", "arm_mask")  # info keys of the (Q, Q) cell masks, in channel order


def map_side(n_actions: int) -> int:
    """Q from the size of the Discrete space, (L + K) * Q * Q."""
    q = math.isqrt(n_actions // NUM_MAPS)
    if NUM_MAPS * q * q != n_actions:
        raise ValueError(f"{n_actions} actions is not {NUM_MAPS} maps of Q x Q")
    return q


# ------------------------------------------------------------------------- masks
def allowed_actions(masks: th.Tensor, parts: tuple[str, ...] = ALL_PARTS) -> th.Tensor:
    """(N, 2, Q, Q) bool base/arm cell masks -> (N, (L + K) * Q * Q) bool allowed actions.

    Base actions are allowed where the base cell is allowed (every yaw bin), arm actions where
    the arm cell is (every push direction); a part not in ``parts`` is disallowed. A row left
    with nothing allowed (no free cell in a base-only task) falls back to every action of the
    used parts.
    """
    n, q = masks.shape[0], masks.shape[-1]
    base = masks[:, 0].reshape(n, 1, q * q).expand(n, YAW_BINS, q * q).reshape(n, -1) & ("base" in parts)
    arm = masks[:, 1].reshape(n, 1, q * q).expand(n, PUSH_BINS, q * q).reshape(n, -1) & ("arm" in parts)
    allowed = th.cat([base, arm], dim=1)
    empty = ~allowed.any(dim=1)
    if empty.any():
        allowed[empty] = th.cat([th.full((YAW_BINS * q * q,), "base" in parts, device=masks.device),
                                 th.full((PUSH_BINS * q * q,), "arm" in parts, device=masks.device)])
    return allowed


def masked_argmax(q_values: th.Tensor, allowed: th.Tensor) -> th.Tensor:
    """Greedy action among the allowed ones: (N, A), (N, A) bool -> (N,) long."""
    return q_values.masked_fill(~allowed, -th.inf).argmax(dim=1)


def sample_allowed(allowed: np.ndarray) -> np.ndarray:
    """One action per row, uniform over that row's allowed actions (``np.random``, seeded by SB3)."""
    return np.array([np.random.choice(np.flatnonzero(row)) for row in allowed], dtype=np.int64)


def without_actions(allowed: th.Tensor, excluded: list[int]) -> th.Tensor:
    """``allowed`` (N, A) with the ``excluded`` indices disallowed, except in rows left with none."""
    narrowed = allowed.clone()
    narrowed[:, th.as_tensor(excluded, dtype=th.long, device=allowed.device)] = False
    empty = ~narrowed.any(dim=1)
    narrowed[empty] = allowed[empty]
    return narrowed


def without_arm_mask(masks):
    """A copy of (..., 2, Q, Q) masks (numpy or torch) with every arm cell allowed."""
    masks = masks.clone() if th.is_tensor(masks) else np.array(masks, dtype=bool)
    masks[..., 1, :, :] = True
    return masks


def info_masks(info: dict, q: int) -> np.ndarray:
    """(2, Q, Q) bool base/arm cell masks of one info dict; all allowed where a mask is absent."""
    return np.stack([np.asarray(info.get(key, np.ones((q, q), bool)), dtype=bool) for key in MASK_KEYS])


def masks_from_infos(infos, q: int) -> np.ndarray:
    """(N, 2, Q, Q) bool from a list of info dicts."""
    return np.stack([info_masks(info, q) for info in infos])


class CellMaskTracker(VecEnvWrapper):
    """Records ``masks`` (n_envs, 2, Q, Q): each sub-environment's latest base and arm cell masks."""

    def __init__(self, venv: VecEnv):
        super().__init__(venv)
        self.q = map_side(int(venv.action_space.n))
        self.masks = np.ones((venv.num_envs, len(MASK_KEYS), self.q, self.q), dtype=bool)

    def reset(self):
        observations = self.venv.reset()
        self.reset_infos = self.venv.unwrapped.reset_infos
        self.masks = masks_from_infos(self.reset_infos, self.q)
        return observations

    def step_wait(self):
        observations, rewards, dones, infos = self.venv.step_wait()
        self.reset_infos = self.venv.unwrapped.reset_infos
        for index, done in enumerate(dones):
            self.masks[index] = info_masks(self.reset_infos[index] if done else infos[index], self.q)
        return observations, rewards, dones, infos


class NoOpMemory:
    """The test-time rule of ``relmogen eval --skip-no-ops`` (ours; never used in training).

    A deterministic SGP-D policy whose subgoal changed nothing it sees gets the same observation
    back and chooses the same subgoal until the episode ends. With this rule a subgoal after
    which the view was unchanged (``view_unchanged``) is excluded until the view changes, so the
    policy falls back to its next best subgoal. Call ``clear`` at every episode start.
    """

    def __init__(self):
        self.clear()

    def clear(self) -> None:
        self.previous: tuple[dict, int] | None = None
        self.excluded: list[int] = []

    def excluded_now(self, obs: dict) -> list[int]:
        """The actions to exclude in ``obs``, given the previous observation and action."""
        if self.previous is not None and view_unchanged(self.previous[0], obs):
            self.excluded.append(self.previous[1])
        else:
            self.excluded = []
        return self.excluded

    def chose(self, obs: dict, action: int) -> None:
        self.previous = ({key: np.array(obs[key]) for key in VIEW_KEYS if key in obs}, int(action))


def env_policy(model: RelmogenDQN, env, deterministic: bool = True, skip_no_ops: bool = False):
    """``obs -> action`` for a single (unvectorised) ``RelmogenEnv``, masked with its current
    cell masks (read from ``env.unwrapped.control``), e.g. for ``rollout.run_episodes``.
    ``skip_no_ops`` applies ``NoOpMemory``; the returned callable's ``reset`` starts an episode."""
    control = env.unwrapped.control
    memory = NoOpMemory() if skip_no_ops else None

    def act(obs):
        masks = info_masks(control.extra_info(), model.q)
        excluded = memory.excluded_now(obs) if memory else None
        action = model.predict(obs, deterministic=deterministic, masks=masks, excluded=excluded)[0]
        if memory:
            memory.chose(obs, action)
        return action

    act.reset = memory.clear if memory else (lambda: None)
    return act


# ------------------------------------------------------------------------ policy
class QMapQNetwork(BasePolicy):
    """SB3's ``QNetwork`` interface (``forward`` -> Q values, ``_predict`` -> argmax) over a ``QMapNetwork``."""

    def __init__(self, observation_space: spaces.Dict, action_space: spaces.Discrete,
                 widths: tuple[int, ...] = (32, 64, 64, 128), head_width: int = 128, skip: bool = False,
                 normalize_images: bool = False):
        super().__init__(observation_space, action_space, normalize_images=False)  # the net scales its inputs
        self.widths, self.head_width, self.skip = tuple(widths), int(head_width), bool(skip)
        self.net = QMapNetwork(observation_space, self.widths, self.head_width, self.skip)
        if self.net.n_actions != action_space.n:
            raise ValueError(f"Q maps give {self.net.n_actions} actions, the action space has {action_space.n}")

    def forward(self, obs: TensorDict) -> th.Tensor:
        return self.net(obs)

    def _predict(self, observation: TensorDict, deterministic: bool = True) -> th.Tensor:
        return self(observation).argmax(dim=1).reshape(-1)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return dict(super()._get_constructor_parameters(), widths=self.widths, head_width=self.head_width,
                    skip=self.skip)


class QMapDQNPolicy(DQNPolicy):
    """``DQNPolicy`` whose ``q_net`` and ``q_net_target`` are ``QMapQNetwork``s (no features extractor)."""

    def __init__(self, observation_space: spaces.Dict, action_space: spaces.Discrete, lr_schedule,
                 widths: tuple[int, ...] = (32, 64, 64, 128), head_width: int = 128, skip: bool = False,
                 **kwargs: Any):
        self.widths, self.head_width, self.skip = tuple(widths), int(head_width), bool(skip)
        kwargs["normalize_images"] = False
        super().__init__(observation_space, action_space, lr_schedule, **kwargs)

    def make_q_net(self) -> QMapQNetwork:
        return QMapQNetwork(self.observation_space, self.action_space, self.widths, self.head_width,
                            self.skip).to(self.device)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return dict(super()._get_constructor_parameters(), widths=self.widths, head_width=self.head_width,
                    skip=self.skip)


# ------------------------------------------------------------------ replay buffer
class QMapReplaySamples(NamedTuple):
    observations: TensorDict
    actions: th.Tensor
    next_observations: TensorDict
    dones: th.Tensor
    rewards: th.Tensor
    discounts: th.Tensor | None = None
    next_masks: th.Tensor | None = None
    masks: th.Tensor | None = None
    labels: th.Tensor | None = None  # (B,) long: the expert's action for the margin term, -1 for none


class QMapReplayBuffer(CompactDictReplayBuffer):
    """``CompactDictReplayBuffer`` (float16 ``depth``) with the state's and next state's cell masks per
    transition. ``masks`` rows are the masks the action was chosen under (``acting_masks``, set
    by ``RelmogenDQN._store_transition`` before each ``add``); rows added without them allow every cell.

    Rows added while ``adding_demonstrations`` is set are marked in ``demo``. With
    ``keep_demonstrations`` the ring skips them, so they stay for the whole run (DQfD keeps its
    demonstrations the same way; ours, off by default).

    ``labels`` (rows, n_envs) holds each transition's expert action for the margin term, -1 for
    none: a demonstration's own action, or the oracle's label of a policy state
    (``acting_labels``, set like ``acting_masks``; ``algo.oracle_labels``).

    With ``n_step_returns`` > 1 samples carry n-step rewards and their ``discounts`` (module doc);
    ``RelmogenDQN`` sets it and ``gamma`` before sampling."""

    def __init__(self, buffer_size: int, observation_space: spaces.Dict, action_space: spaces.Discrete,
                 *args: Any, keep_demonstrations: bool = False, **kwargs: Any):
        super().__init__(buffer_size, observation_space, action_space, *args, **kwargs)
        self.keep_demonstrations = bool(keep_demonstrations)
        self.n_step_returns, self.gamma = 1, 0.99
        self.adding_demonstrations = False
        self.acting_masks = self.acting_labels = None
        self.demo = np.zeros(self.buffer_size, dtype=bool)
        self.labels = np.full((self.buffer_size, self.n_envs), -1, dtype=np.int64)
        q = map_side(int(action_space.n))
        self.next_masks = np.ones((self.buffer_size, self.n_envs, len(MASK_KEYS), q, q), dtype=bool)
        self.masks = np.ones_like(self.next_masks)

    def __setstate__(self, state: dict) -> None:
        """Older buffers load too: without arm masks their arm cells are allowed; without the
        state's own masks they are taken from the previous transition's next masks."""
        state = with_full_capacity(state)
        if "next_base_masks" in state:
            base = state.pop("next_base_masks")
            state["next_masks"] = np.stack([base, np.ones_like(base)], axis=2)
        state = {"keep_demonstrations": False, "adding_demonstrations": False, "acting_masks": None,
                 "acting_labels": None, "n_step_returns": 1, "gamma": 0.99, **state}
        self.__dict__.update(state)
        if "masks" not in state:
            self.masks = masks_before(self.next_masks, self.dones, self.pos, self.full)
        if "demo" not in state:
            self.demo = np.zeros(self.buffer_size, dtype=bool)
        if "labels" not in state:  # demonstrations were labelled by their own action
            self.labels = np.where(self.demo[:, None], self.actions[..., 0], -1).astype(np.int64)

    def add(self, obs, next_obs, action, reward, done, infos) -> None:
        if self.keep_demonstrations:
            self._skip_demonstration_rows()
        self.masks[self.pos] = True if self.acting_masks is None else self.acting_masks
        self.acting_masks = None
        self.next_masks[self.pos] = masks_from_infos(infos, self.next_masks.shape[-1])
        self.demo[self.pos] = self.adding_demonstrations
        self.labels[self.pos] = self._labels_of(action)
        super().add(obs, next_obs, action, reward, done, infos)

    def _labels_of(self, action) -> np.ndarray:
        """The expert actions of the row being added: its own for demonstrations, else ``acting_labels``."""
        labels = np.asarray(action).reshape(self.n_envs) if self.adding_demonstrations else self.acting_labels
        self.acting_labels = None
        return -1 if labels is None else labels

    def _skip_demonstration_rows(self) -> None:
        """Move ``pos`` past kept demonstration rows (wrapping round as SB3's ``add`` does)."""
        for _ in range(self.buffer_size):
            if not self.demo[self.pos]:
                return
            self.pos = (self.pos + 1) % self.buffer_size
            self.full = self.full or self.pos == 0
        raise ValueError(f"demonstrations fill all {self.buffer_size} rows of the replay buffer: raise "
                         "algo.buffer_size or lower algo.demo_episodes")

    def nbytes(self) -> int:
        """Bytes held by the stored arrays."""
        extras = [self.next_masks, self.masks, self.demo, self.labels]
        return super().nbytes() + int(sum(array.nbytes for array in extras))

    def _get_samples(self, batch_inds: np.ndarray, env=None) -> QMapReplaySamples:
        envs = np.random.randint(0, high=self.n_envs, size=(len(batch_inds),))
        rows = self.n_step_rows(batch_inds, envs)  # (B, n): the steps each target sums, rows[:, 0] = batch_inds
        steps = (rows >= 0).sum(axis=1)
        last = rows[np.arange(len(rows)), steps - 1]
        weights = np.where(rows >= 0, self.gamma ** np.arange(rows.shape[1], dtype=np.float32), 0.0)
        rewards = (self._normalize_reward(self.rewards[rows, envs[:, None]], env) * weights).sum(axis=1)
        discounts = (None if self.n_step_returns == 1  # one-step samples: the algorithm's gamma applies
                     else self.to_torch((self.gamma ** steps).astype(np.float32)).reshape(-1, 1))
        dones = self.dones[last, envs] * (1 - self.timeouts[last, envs])
        return QMapReplaySamples(
            observations=self._batch(self.observations, batch_inds, envs, env),
            actions=self.to_torch(self.actions[batch_inds, envs]),
            next_observations=self._batch(self.next_observations, last, envs, env),
            dones=self.to_torch(dones).reshape(-1, 1),
            rewards=self.to_torch(rewards.astype(np.float32)).reshape(-1, 1),
            discounts=discounts,
            next_masks=self.to_torch(self.next_masks[last, envs]),
            masks=self.to_torch(self.masks[batch_inds, envs]),
            labels=self.to_torch(self.labels[batch_inds, envs]),
        )

    def n_step_rows(self, batch_inds: np.ndarray, envs: np.ndarray) -> np.ndarray:
        """(B, n) rows of the up to ``n_step_returns`` consecutive steps starting at each sampled row,
        -1 past the window's end: the environment's episode end (terminal or time limit), the newest
        row (the next one is older), or a row whose ``demo`` flag differs (the ring skipped kept
        demonstrations there)."""
        rows = (batch_inds[:, None] + np.arange(self.n_step_returns)) % self.buffer_size
        last_step = self.dones[rows, envs[:, None]].astype(bool) | (rows == (self.pos - 1) % self.buffer_size)
        last_step[:, :-1] |= self.demo[rows[:, 1:]] != self.demo[rows[:, :-1]]
        after_end = np.cumsum(last_step, axis=1) - last_step > 0
        return np.where(after_end, -1, rows)


def masks_before(next_masks: np.ndarray, dones: np.ndarray, pos: int, full: bool) -> np.ndarray:
    """Each row's own masks rebuilt from the previous row's next masks (rows are consecutive
    steps of each environment); after an episode end, and for the oldest row, every cell."""
    previous = np.roll(next_masks, 1, axis=0)
    known = ~np.roll(dones.astype(bool), 1, axis=0)
    known[pos if full else 0] = False
    return np.where(known[:, :, None, None, None], previous, True)


# --------------------------------------------------------------------- algorithm
class RelmogenDQN(DQN):
    """SB3 DQN + Double DQN targets + mask-aware exploration and greedy choice (module doc)."""

    def __init__(self, policy=QMapDQNPolicy, env=None, *, subgoal_parts: tuple[str, ...] = ALL_PARTS,
                 mask_arm: bool = True,
                 learning_rate: float = 2.5e-4, buffer_size: int = 10_000, batch_size: int = 512,
                 gamma: float = 0.99, target_update_interval: int = 1024, tau: float = 1.0,
                 max_grad_norm: float = 10.0, exploration_initial_eps: float = 0.8,
                 exploration_final_eps: float = 0.04, exploration_steps: int | None = None,
                 conservative_weight: float = 0.0, demo_margin_weight: float = 0.0, n_step_returns: int = 1,
                 oracle_labels: bool = False, replay_buffer_class=QMapReplayBuffer, **kwargs: Any):
        self.subgoal_parts = tuple(subgoal_parts)
        self.mask_arm = bool(mask_arm)
        self.exploration_steps = exploration_steps
        self.conservative_weight = float(conservative_weight)
        self.demo_margin_weight = float(demo_margin_weight)
        self.n_step_returns = int(n_step_returns)  # not SB3's ``n_steps``: that one wants SB3's own buffer
        self.oracle_labels = bool(oracle_labels)
        super().__init__(policy, env, learning_rate=learning_rate, buffer_size=buffer_size, batch_size=batch_size,
                         gamma=gamma, target_update_interval=target_update_interval, tau=tau,
                         max_grad_norm=max_grad_norm, exploration_initial_eps=exploration_initial_eps,
                         exploration_final_eps=exploration_final_eps, replay_buffer_class=replay_buffer_class,
                         **kwargs)

    def _setup_model(self) -> None:
        self.subgoal_parts = tuple(self.subgoal_parts)  # ``load`` restores it from JSON as a list
        self._acting_labels, self._label_agreement = None, deque(maxlen=LABEL_AGREEMENT_WINDOW)  # runtime only
        super()._setup_model()

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_acting_masks", "_acting_labels", "_label_agreement"]

    @staticmethod
    def _wrap_env(env, verbose: int = 0, monitor_wrapper: bool = True) -> VecEnv:
        env = DQN._wrap_env(env, verbose, monitor_wrapper)
        return env if is_vecenv_wrapped(env, CellMaskTracker) else CellMaskTracker(env)

    @property
    def q(self) -> int:
        return map_side(int(self.action_space.n))

    def tracked_masks(self, n_envs: int) -> np.ndarray:
        tracker = self.env if isinstance(self.env, CellMaskTracker) else None
        if tracker is None or tracker.masks.shape[0] != n_envs:
            return np.ones((n_envs, len(MASK_KEYS), self.q, self.q), dtype=bool)
        return tracker.masks.copy()

    def allowed(self, masks: np.ndarray | th.Tensor | None, n: int) -> th.Tensor:
        """(N, (L + K) Q Q) allowed actions from (N, 2, Q, Q) masks (None: all cells allowed)."""
        shape = (n, len(MASK_KEYS), self.q, self.q)
        if masks is None:
            masks = th.ones(shape, dtype=th.bool, device=self.device)
        masks = th.as_tensor(masks, dtype=th.bool, device=self.device).reshape(shape)
        return allowed_actions(masks if self.mask_arm else without_arm_mask(masks), self.subgoal_parts)

    # ---------------------------------------------------------------- acting
    def _on_step(self) -> None:
        """SB3's target update and epsilon; with ``exploration_steps`` epsilon decays linearly over that
        many environment steps instead of a fraction of ``total_timesteps`` (which ``relmogen train``
        sets to 1e12)."""
        super()._on_step()
        if self.exploration_steps:
            progress = min(1.0, self.num_timesteps / self.exploration_steps)
            start, end = self.exploration_initial_eps, self.exploration_final_eps
            self.exploration_rate = start + progress * (end - start)
            self.logger.record("rollout/exploration_rate", self.exploration_rate)

    def _sample_action(self, learning_starts: int, action_noise=None, n_envs: int = 1):
        masks = self._acting_masks = self.tracked_masks(n_envs)
        if self.oracle_labels:  # before acting: the label is the oracle's choice in this state
            self._acting_labels = np.asarray(self.env.env_method(ORACLE_LABEL_METHOD), dtype=np.int64)
        if self.num_timesteps < learning_starts:
            action = sample_allowed(self.allowed(masks, n_envs).cpu().numpy())
        else:
            action, _ = self.predict(self._last_obs, deterministic=False, masks=masks)
        return action, action

    def _store_transition(self, replay_buffer, buffer_action, new_obs, reward, dones, infos) -> None:
        if isinstance(replay_buffer, QMapReplayBuffer):
            replay_buffer.acting_masks = self._acting_masks
            replay_buffer.acting_labels = self._acting_labels
        if self._acting_labels is not None:
            self._label_agreement.extend(np.asarray(buffer_action).reshape(-1) == self._acting_labels)
            self._acting_labels = None
        super()._store_transition(replay_buffer, buffer_action, new_obs, reward, dones, infos)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = False,
                masks: np.ndarray | None = None, excluded: list[int] | None = None):
        """Epsilon-greedy (one coin per observation) over allowed actions; ``masks`` (N, 2, Q, Q) or (2, Q, Q);
        ``excluded`` action indices are disallowed in every row unless that leaves a row nothing."""
        self.policy.set_training_mode(False)
        obs, vectorized = self.policy.obs_to_tensor(observation)
        n = next(iter(obs.values())).shape[0]
        allowed = self.allowed(masks, n)
        if excluded:
            allowed = without_actions(allowed, excluded)
        explore = np.zeros(n, bool) if deterministic else np.random.rand(n) < self.exploration_rate
        actions = np.empty(n, dtype=np.int64)
        if not explore.all():
            with th.no_grad():
                actions[:] = masked_argmax(self.q_net(obs), allowed).cpu().numpy()
        if explore.any():
            actions[explore] = sample_allowed(allowed[th.as_tensor(explore)].cpu().numpy())
        return (actions if vectorized else actions[0]), state

    # -------------------------------------------------------------- learning
    def double_dqn_targets(self, data) -> th.Tensor:
        """r + gamma (1 - done) Q_target(s', argmax_a' Q_online(s', a')), argmax over allowed a'."""
        with th.no_grad():
            online = self.q_net(data.next_observations)
            best = masked_argmax(online, self.allowed(getattr(data, "next_masks", None), online.shape[0]))
            best = best.reshape(-1, 1)
            next_q = self.q_net_target(data.next_observations).gather(1, best)
            discounts = data.discounts if data.discounts is not None else self.gamma
            return data.rewards + (1 - data.dones) * discounts * next_q

    def train(self, gradient_steps: int, batch_size: int = 100) -> None:
        self.policy.set_training_mode(True)
        self._update_learning_rate(self.policy.optimizer)
        if isinstance(self.replay_buffer, QMapReplayBuffer):  # both may change on a resume
            self.replay_buffer.n_step_returns, self.replay_buffer.gamma = self.n_step_returns, self.gamma
        losses = np.array([self._gradient_step(self.replay_buffer.sample(batch_size, env=self._vec_normalize_env))
                           for _ in range(gradient_steps)])
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.record("train/loss", float(losses[:, 0].mean()))
        if self.conservative_weight:
            self.logger.record("train/conservative_gap", float(losses[:, 1].mean()))
        if self.demo_margin_weight:
            self.logger.record("train/demo_margin_loss", float(losses[:, 2].mean()))
        if self._label_agreement:
            self.logger.record("rollout/oracle_agreement", float(np.mean(self._label_agreement)))

    def conservative_gap(self, q_values: th.Tensor, taken: th.Tensor, masks: th.Tensor | None) -> th.Tensor:
        """Mean over the batch of logsumexp over allowed actions of Q(s, .) minus Q(s, a_taken)."""
        allowed = self.allowed(masks, q_values.shape[0])
        return (q_values.masked_fill(~allowed, -th.inf).logsumexp(dim=1, keepdim=True) - taken).mean()

    def demonstration_margin(self, q_values: th.Tensor, data) -> th.Tensor:
        """DQfD's large-margin loss, mean over the batch's labelled rows (0 without any): max over
        allowed a of [Q(s, a) + 0.8 if a is not the expert's a_E] minus Q(s, a_E). a_E is
        ``data.labels``: a demonstration's own action or the oracle's label of a policy state."""
        labelled = data.labels >= 0 if data.labels is not None else None
        if labelled is None or not labelled.any():
            return th.zeros((), device=q_values.device)
        q_values, taken = q_values[labelled], data.labels.long()[labelled].reshape(-1, 1)
        expert = F.one_hot(taken.reshape(-1), q_values.shape[1]).bool()
        masks = data.masks[labelled] if data.masks is not None else None
        allowed = self.allowed(masks, q_values.shape[0]) | expert
        best = (q_values + DQFD_MARGIN * ~expert).masked_fill(~allowed, -th.inf).max(dim=1).values
        return (best - q_values.gather(1, taken).reshape(-1)).mean()

    def _gradient_step(self, data) -> tuple[float, float, float]:
        """One update; returns (Huber TD loss, conservative gap, demonstration margin loss)."""
        targets = self.double_dqn_targets(data)
        q_values = self.q_net(data.observations)
        current = q_values.gather(1, data.actions.long())
        td_loss = F.smooth_l1_loss(current, targets)
        no_term = th.zeros((), device=q_values.device)
        gap = self.conservative_gap(q_values, current, data.masks) if self.conservative_weight else no_term
        margin = self.demonstration_margin(q_values, data) if self.demo_margin_weight else no_term
        loss = td_loss + self.conservative_weight * gap + self.demo_margin_weight * margin
        self.policy.optimizer.zero_grad()
        loss.backward()
        th.nn.utils.clip_grad_norm_(self.policy.parameters(), self.max_grad_norm)
        self.policy.optimizer.step()
        return td_loss.item(), gap.item(), margin.item()
