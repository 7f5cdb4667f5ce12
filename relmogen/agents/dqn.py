"""SGP-D: masked Double DQN over dense per-pixel Q maps (``relmogen-d``; facts sheet sections 5-6).

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

``CellMaskReplayBuffer`` stores depth as float16 (<= 3 m: step <= 2 mm), and per transition
the next state's masks and the masks its action was chosen under; SB3's
``optimize_memory_usage`` is not available for Dict observations.

Optional research add-ons, all ours and off by default, live in ``relmogen/agents/addons/``
(each module's docstring says what it adds, where it comes from and what measured it):
``conservative_weight`` (CQL), ``demo_margin_weight`` (DQfD's margin), ``keep_demonstrations``
(the replay's ``algo.demo_keep``), ``n_step_returns``, ``oracle_labels`` (DAgger-style
labels), ``exploration_temperature`` (Boltzmann exploration), ``priority_alpha`` (prioritized
replay) and ``shift_cells`` (shift augmentation of arm pushes); ``env_policy(skip_no_ops=True)``
is a test-time rule. ``QMapReplayBuffer`` is ``CellMaskReplayBuffer`` with the add-ons' replay
mixins, and ``RelmogenDQN`` adds their loss terms to the Huber loss; with every add-on off it is
the plain masked Double DQN.
"""

from __future__ import annotations

import math
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

from relmogen.agents.addons import LossTerm
from relmogen.agents.addons.boltzmann_exploration import boltzmann_sample
from relmogen.agents.addons.conservative import conservative_term
from relmogen.agents.addons.demonstration_margin import ExpertLabels, demonstration_margin_term
from relmogen.agents.addons.kept_demonstrations import DemonstrationRows
from relmogen.agents.addons.n_step import NStepReturns, use_n_step_returns
from relmogen.agents.addons.oracle_labels import OracleLabeller
from relmogen.agents.addons.prioritized_replay import (PrioritizedRows, annealed_beta, use_prioritized_replay,
                                                       weighted_td_loss)
from relmogen.agents.addons.shift_augmentation import shift_arm_pushes
from relmogen.agents.addons.skip_no_ops import NoOpMemory
from relmogen.agents.allocator import keep_freed_memory_once
from relmogen.agents.qmap_network import NUM_MAPS, QMapNetwork
from relmogen.agents.replay import CompactDictReplayBuffer, with_full_capacity
from relmogen.envs.subgoal_controls import PUSH_BINS, YAW_BINS

ALL_PARTS = ("base", "arm")
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
                 bf16: bool = False, normalize_images: bool = False, unet: bool = False, head_kernel: int = 4):
        super().__init__(observation_space, action_space, normalize_images=False)  # the net scales its inputs
        self.widths, self.head_width, self.skip, self.bf16 = tuple(widths), int(head_width), bool(skip), bool(bf16)
        self.unet, self.head_kernel = bool(unet), int(head_kernel)
        self.net = QMapNetwork(observation_space, self.widths, self.head_width, self.skip, q=map_side(action_space.n),
                               bf16=self.bf16, unet=self.unet, head_kernel=self.head_kernel)
        if self.net.n_actions != action_space.n:
            raise ValueError(f"Q maps give {self.net.n_actions} actions, the action space has {action_space.n}")

    def forward(self, obs: TensorDict) -> th.Tensor:
        return self.net(obs)

    def _predict(self, observation: TensorDict, deterministic: bool = True) -> th.Tensor:
        return self(observation).argmax(dim=1).reshape(-1)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return dict(super()._get_constructor_parameters(), widths=self.widths, head_width=self.head_width,
                    skip=self.skip, bf16=self.bf16, unet=self.unet, head_kernel=self.head_kernel)


class QMapDQNPolicy(DQNPolicy):
    """``DQNPolicy`` whose ``q_net`` and ``q_net_target`` are ``QMapQNetwork``s (no features extractor)."""

    def __init__(self, observation_space: spaces.Dict, action_space: spaces.Discrete, lr_schedule,
                 widths: tuple[int, ...] = (32, 64, 64, 128), head_width: int = 128, skip: bool = False,
                 bf16: bool = False, unet: bool = False, head_kernel: int = 4, **kwargs: Any):
        self.widths, self.head_width, self.skip, self.bf16 = tuple(widths), int(head_width), bool(skip), bool(bf16)
        self.unet, self.head_kernel = bool(unet), int(head_kernel)
        kwargs["normalize_images"] = False
        super().__init__(observation_space, action_space, lr_schedule, **kwargs)

    def make_q_net(self) -> QMapQNetwork:
        return QMapQNetwork(self.observation_space, self.action_space, self.widths, self.head_width,
                            self.skip, self.bf16, unet=self.unet, head_kernel=self.head_kernel).to(self.device)

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return dict(super()._get_constructor_parameters(), widths=self.widths, head_width=self.head_width,
                    skip=self.skip, bf16=self.bf16, unet=self.unet, head_kernel=self.head_kernel)


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
    weights: th.Tensor | None = None  # (B, 1) importance weights of prioritized replay


def masks_before(next_masks: np.ndarray, dones: np.ndarray, pos: int, full: bool) -> np.ndarray:
    """Each row's own masks rebuilt from the previous row's next masks (rows are consecutive
    steps of each environment); after an episode end, and for the oldest row, every cell."""
    previous = np.roll(next_masks, 1, axis=0)
    known = ~np.roll(dones.astype(bool), 1, axis=0)
    known[pos if full else 0] = False
    return np.where(known[:, :, None, None, None], previous, True)


class CellMaskReplayBuffer(CompactDictReplayBuffer):
    """``CompactDictReplayBuffer`` (float16 ``depth``) with each transition's cell masks:
    ``next_masks``, the next state's, which the Double DQN target's argmax obeys, and ``masks``,
    the ones its action was chosen under (``acting_masks``, set by ``RelmogenDQN._store_transition``
    before each ``add``; rows added without them allow every cell).

    Replay mixins (``relmogen/agents/addons``) go in front of it and extend ``add``,
    ``upgraded_state`` (what an older pickle lacks), ``returns`` (what a target sums and where it
    bootstraps) and ``samples_at``."""

    def __init__(self, buffer_size: int, observation_space: spaces.Dict, action_space: spaces.Discrete,
                 *args: Any, **kwargs: Any):
        super().__init__(buffer_size, observation_space, action_space, *args, **kwargs)
        self.acting_masks = None
        q = map_side(int(action_space.n))
        self.next_masks = np.ones((self.buffer_size, self.n_envs, len(MASK_KEYS), q, q), dtype=bool)
        self.masks = np.ones_like(self.next_masks)

    def __setstate__(self, state: dict) -> None:
        super().__setstate__(self.upgraded_state(with_full_capacity(state)))

    def upgraded_state(self, state: dict) -> dict:
        """Older buffers load too: without arm masks their arm cells are allowed; without the
        state's own masks they are taken from the previous transition's next masks."""
        state = {"acting_masks": None, **state}
        if "next_base_masks" in state:
            base = state.pop("next_base_masks")
            state["next_masks"] = np.stack([base, np.ones_like(base)], axis=2)
        if "masks" not in state:
            state["masks"] = masks_before(state["next_masks"], state["dones"], state["pos"], state["full"])
        return state

    def add(self, obs, next_obs, action, reward, done, infos) -> None:
        self.masks[self.pos] = True if self.acting_masks is None else self.acting_masks
        self.acting_masks = None
        self.next_masks[self.pos] = masks_from_infos(infos, self.next_masks.shape[-1])
        super().add(obs, next_obs, action, reward, done, infos)

    def nbytes(self) -> int:
        """Bytes held by the stored arrays."""
        return super().nbytes() + self.next_masks.nbytes + self.masks.nbytes

    def _get_samples(self, batch_inds: np.ndarray, env=None) -> QMapReplaySamples:
        envs = np.random.randint(0, high=self.n_envs, size=(len(batch_inds),))
        return self.samples_at(batch_inds, envs, env)

    def samples_at(self, batch_inds: np.ndarray, envs: np.ndarray, env=None) -> QMapReplaySamples:
        """The transitions of environments ``envs`` at rows ``batch_inds``; each target's rewards,
        discount and bootstrap row come from ``returns``."""
        rewards, discounts, last = self.returns(batch_inds, envs, env)
        dones = self.dones[last, envs] * (1 - self.timeouts[last, envs])
        return QMapReplaySamples(
            observations=self._batch(self.observations, batch_inds, envs, env),
            actions=self.to_torch(self.actions[batch_inds, envs]),
            next_observations=self._batch(self.next_observations, last, envs, env),
            dones=self.to_torch(dones).reshape(-1, 1),
            rewards=self.to_torch(rewards).reshape(-1, 1),
            discounts=None if discounts is None else self.to_torch(discounts).reshape(-1, 1),
            next_masks=self.to_torch(self.next_masks[last, envs]),
            masks=self.to_torch(self.masks[batch_inds, envs]),
        )

    def returns(self, batch_inds: np.ndarray, envs: np.ndarray, env=None):
        """One-step targets: each row's own (B,) reward, no discount of its own (the algorithm's
        gamma applies) and the row itself to bootstrap from."""
        return self._normalize_reward(self.rewards[batch_inds, envs], env).astype(np.float32), None, batch_inds


class QMapReplayBuffer(DemonstrationRows, PrioritizedRows, ExpertLabels, NStepReturns, CellMaskReplayBuffer):
    """relmogen-d's replay: ``CellMaskReplayBuffer`` with the add-ons' rows and columns. ``demo`` marks
    demonstration rows (kept with ``keep_demonstrations``), ``priorities`` drive prioritized
    sampling when ``priority_alpha`` > 0, ``labels`` holds each row's expert action for the margin
    term, and with ``n_step_returns`` > 1 samples carry n-step rewards and their ``discounts``
    (``RelmogenDQN`` sets these and ``gamma`` before sampling)."""



# --------------------------------------------------------------------- algorithm
class RelmogenDQN(DQN):
    """SB3 DQN + Double DQN targets + mask-aware exploration and greedy choice (module doc); the
    add-ons' arguments (``conservative_weight``, ``demo_margin_weight``, ``n_step_returns``,
    ``oracle_labels``, ``exploration_temperature``, ``priority_alpha``, ``priority_beta``, ``shift_cells``)
    are described in ``relmogen/agents/addons``."""

    def __init__(self, policy=QMapDQNPolicy, env=None, *, subgoal_parts: tuple[str, ...] = ALL_PARTS,
                 mask_arm: bool = True,
                 learning_rate: float = 2.5e-4, buffer_size: int = 10_000, batch_size: int = 512,
                 gamma: float = 0.99, target_update_interval: int = 1024, tau: float = 1.0,
                 max_grad_norm: float = 10.0, exploration_initial_eps: float = 0.8,
                 exploration_final_eps: float = 0.04, exploration_steps: int | None = None,
                 conservative_weight: float = 0.0, demo_margin_weight: float = 0.0, n_step_returns: int = 1,
                 oracle_labels: bool = False, exploration_temperature: float = 0.0,
                 priority_alpha: float = 0.0, priority_beta: float = 0.4, shift_cells: int = 0,
                 replay_buffer_class=QMapReplayBuffer, **kwargs: Any):
        self.subgoal_parts = tuple(subgoal_parts)
        self.mask_arm = bool(mask_arm)
        self.exploration_steps = exploration_steps
        self.conservative_weight = float(conservative_weight)
        self.demo_margin_weight = float(demo_margin_weight)
        self.n_step_returns = int(n_step_returns)  # not SB3's ``n_steps``: that one wants SB3's own buffer
        self.oracle_labels = bool(oracle_labels)
        self.exploration_temperature = float(exploration_temperature)
        self.priority_alpha, self.priority_beta = float(priority_alpha), float(priority_beta)
        self.shift_cells = int(shift_cells)
        super().__init__(policy, env, learning_rate=learning_rate, buffer_size=buffer_size, batch_size=batch_size,
                         gamma=gamma, target_update_interval=target_update_interval, tau=tau,
                         max_grad_norm=max_grad_norm, exploration_initial_eps=exploration_initial_eps,
                         exploration_final_eps=exploration_final_eps, replay_buffer_class=replay_buffer_class,
                         **kwargs)

    def _setup_model(self) -> None:
        """Runtime state from the saved settings (construction and ``load`` both come here)."""
        self.subgoal_parts = tuple(self.subgoal_parts)  # ``load`` restores it from JSON as a list
        self._acting_masks = None
        self._oracle_labeller = OracleLabeller() if self.oracle_labels else None
        super()._setup_model()

    def active_loss_terms(self) -> list[LossTerm]:
        """The add-ons' loss terms with a nonzero weight, in the order they join the Huber loss."""
        terms = [conservative_term(self.conservative_weight), demonstration_margin_term(self.demo_margin_weight)]
        return [term for term in terms if term.weight]

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "_acting_masks", "_oracle_labeller"]

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
        if self._oracle_labeller is not None:  # before acting: the label is the oracle's choice in this state
            self._oracle_labeller.ask(self.env)
        if self.num_timesteps < learning_starts:
            action = sample_allowed(self.allowed(masks, n_envs).cpu().numpy())
        else:
            action, _ = self.predict(self._last_obs, deterministic=False, masks=masks)
        return action, action

    def _store_transition(self, replay_buffer, buffer_action, new_obs, reward, dones, infos) -> None:
        if isinstance(replay_buffer, CellMaskReplayBuffer):
            replay_buffer.acting_masks = self._acting_masks
        if self._oracle_labeller is not None:
            self._oracle_labeller.hand_over(replay_buffer, buffer_action)
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
        boltzmann = self.exploration_temperature > 0
        actions = np.empty(n, dtype=np.int64)
        if not explore.all() or (explore.any() and boltzmann):
            with th.no_grad():
                q_values = self.q_net(obs)
            actions[:] = masked_argmax(q_values, allowed).cpu().numpy()
        if explore.any():
            rows = th.as_tensor(explore)
            actions[explore] = (boltzmann_sample(q_values[rows], allowed[rows], self.exploration_temperature)
                                if boltzmann else sample_allowed(allowed[rows].cpu().numpy()))
        return (actions if vectorized else actions[0]), state

    # -------------------------------------------------------------- learning
    def double_dqn_targets(self, data) -> th.Tensor:
        """r + gamma (1 - done) Q_target(s', argmax_a' Q_online(s', a')), argmax over allowed a'; a
        sample's own ``discounts`` (n-step returns) replace gamma."""
        with th.no_grad():
            online = self.q_net(data.next_observations)
            best = masked_argmax(online, self.allowed(getattr(data, "next_masks", None), online.shape[0]))
            best = best.reshape(-1, 1)
            next_q = self.q_net_target(data.next_observations).gather(1, best)
            discounts = data.discounts if data.discounts is not None else self.gamma
            return data.rewards + (1 - data.dones) * discounts * next_q

    def train(self, gradient_steps: int, batch_size: int = 100) -> None:
        keep_freed_memory_once()  # glibc keeps the update's freed activations (relmogen.agents.allocator)
        self.policy.set_training_mode(True)
        self._update_learning_rate(self.policy.optimizer)
        use_n_step_returns(self.replay_buffer, self.n_step_returns, self.gamma)
        use_prioritized_replay(self.replay_buffer, self.priority_alpha,
                               annealed_beta(self.priority_beta, self.num_timesteps, self.exploration_steps))
        steps = [self._gradient_step(self.replay_buffer.sample(batch_size, env=self._vec_normalize_env))
                 for _ in range(gradient_steps)]
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        for key in steps[0]:
            self.logger.record(f"train/{key}", float(np.mean([step[key] for step in steps])))
        if self._oracle_labeller is not None:
            self._oracle_labeller.record(self.logger)

    def _gradient_step(self, data) -> dict[str, float]:
        """One update; returns the Huber TD loss (``loss``), the mean Q of the taken actions
        (``q_taken``) and of their targets (``target``), which show a diverging Q function before
        the returns do, and the value of each active loss term."""
        targets = self.double_dqn_targets(data)
        observations, actions = data.observations, data.actions
        if self.shift_cells:
            observations, actions = shift_arm_pushes(observations, actions, self.q, self.shift_cells,
                                                     self.q_net.net.rgb_channels_first)
        q_values = self.q_net(observations)
        current = q_values.gather(1, actions.long())
        errors = F.smooth_l1_loss(current, targets, reduction="none")
        td_loss = weighted_td_loss(errors, getattr(data, "weights", None))
        loss_terms = self.active_loss_terms()
        terms = {term.name: term.value(q_values, current, data, self.allowed) for term in loss_terms}
        loss = td_loss
        for term in loss_terms:
            loss = loss + term.weight * terms[term.name]
        self.policy.optimizer.zero_grad()
        loss.backward()
        th.nn.utils.clip_grad_norm_(self.policy.parameters(), self.max_grad_norm)
        self.policy.optimizer.step()
        if getattr(data, "weights", None) is not None:
            self.replay_buffer.update_priorities((targets - current).detach().cpu().numpy())
        return {"loss": td_loss.item(), "q_taken": current.mean().item(), "target": targets.mean().item(),
                **{name: value.item() for name, value in terms.items()}}
