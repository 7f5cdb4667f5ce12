"""Environments, batches and buffers shared by the relmogen-d tests (``test_dqn*.py``)."""

import gymnasium as gym
import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.dqn import QMapReplayBuffer, QMapReplaySamples, RelmogenDQN, allowed_actions
from relmogen.agents.qmap_network import NUM_MAPS
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import YAW_BINS

SIZE = 64
Q = SIZE // 4
SMALL_NET = {"widths": (8, 16, 16, 32), "head_width": 32}


class MaskAudit(gym.Wrapper):
    """Counts actions sent to a masked cell according to the latest ``info["base_mask"]`` and
    ``info["arm_mask"]``."""

    def __init__(self, env, record: dict):
        super().__init__(env)
        self.record, self.masks = record, None

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        self.masks = info
        return obs, info

    def step(self, action):
        part, _, i, j = self.env.unwrapped.control.decode(int(action))
        self.record["steps"] = self.record.get("steps", 0) + 1
        self.record["violations"] = self.record.get("violations", 0) + int(not self.masks[f"{part}_mask"][i, j])
        obs, reward, terminated, truncated, info = self.env.step(action)
        self.masks = info
        return obs, reward, terminated, truncated, info


def make_env(audit=None, qmap_size=None):
    env = RelmogenEnv(task="PointNav", control="subgoal-d", image_size=SIZE, episode_steps=5, qmap_size=qmap_size)
    return env if audit is None else MaskAudit(env, audit)


def transposed_observation_space(size: int) -> spaces.Dict:
    """An SGP-D observation space at ``size`` px as SB3's ``VecTransposeImage`` leaves it."""
    return spaces.Dict({"rgb": spaces.Box(0, 255, (3, size, size), np.uint8),
                        "depth": spaces.Box(0.0, 3.0, (size, size, 1), np.float32),
                        "local_map": spaces.Box(0, 255, (2, size, size), np.uint8),
                        "scan": spaces.Box(0.0, 1.0, (220,), np.float32),
                        "task_obs": spaces.Box(-np.inf, np.inf, (55,), np.float32)})


def random_batch(space: spaces.Dict, n: int, seed: int = 0) -> dict[str, th.Tensor]:
    space.seed(seed)
    samples = [space.sample() for _ in range(n)]
    return {key: th.as_tensor(np.stack([s[key] for s in samples])) for key in space.spaces}


def few_free_cells(n: int, cells=((0, 0), (5, 9), (15, 15)), arm_cells=None) -> np.ndarray:
    """(n, 2, Q, Q) masks: base allowed only at ``cells``; arm at ``arm_cells`` (None: everywhere)."""
    masks = np.zeros((n, 2, Q, Q), dtype=bool)
    for i, j in cells:
        masks[:, 0, i, j] = True
    if arm_cells is None:
        masks[:, 1] = True
    for i, j in arm_cells or ():
        masks[:, 1, i, j] = True
    return masks


def allowed_action_batch(model, n: int = 6) -> QMapReplaySamples:
    """Transitions whose taken actions are allowed (different ones), ending with reward 0."""
    masks = th.as_tensor(few_free_cells(n, arm_cells=((2, 3), (9, 9))))
    allowed = allowed_actions(masks, model.subgoal_parts)
    actions = th.stack([allowed[b].nonzero().ravel()[7 * b] for b in range(n)]).reshape(-1, 1)
    return QMapReplaySamples(observations=random_batch(model.observation_space, n, seed=3), actions=actions,
                             next_observations=random_batch(model.observation_space, n, seed=4),
                             dones=th.ones(n, 1), rewards=th.zeros(n, 1), next_masks=masks, masks=masks)


def updated_on_one_batch(make_batch, updates: int, **weights) -> tuple[dict[str, np.ndarray], th.Tensor,
                                                                       QMapReplaySamples]:
    """A fresh small model updated ``updates`` times on one batch: each loss of every update (by
    name: ``loss`` and the active terms), the final Q values on the batch, and the batch."""
    dqn = RelmogenDQN(env=DummyVecEnv([make_env]), buffer_size=64, batch_size=4, learning_starts=0,
                      policy_kwargs=SMALL_NET, seed=0, learning_rate=3e-3, **weights)
    dqn.policy.set_training_mode(True)
    data = make_batch(dqn)
    steps = [dqn._gradient_step(data) for _ in range(updates)]
    with th.no_grad():
        q_values = dqn.q_net(data.observations)
    dqn.env.close()
    return {key: np.array([step[key] for step in steps]) for key in steps[0]}, q_values, data


def tiny_buffer(rows: int, keep: bool) -> QMapReplayBuffer:
    space = spaces.Dict({"depth": spaces.Box(0.0, 3.0, (2, 2, 1), np.float32)})
    return QMapReplayBuffer(rows, space, spaces.Discrete(NUM_MAPS), device="cpu", keep_demonstrations=keep)


def add_step(buffer: QMapReplayBuffer, row_id: int, reward: float = 0.0, done=False, timeout=False,
             demo=False) -> None:
    """One transition with action ``row_id`` whose next observation's depth is ``row_id`` too (to see
    which row a target bootstraps from)."""
    buffer.adding_demonstrations = demo
    obs, next_obs = {"depth": np.zeros((1, 2, 2, 1), np.float32)}, {"depth": np.full((1, 2, 2, 1), row_id, np.float32)}
    buffer.add(obs, next_obs, np.array([[row_id]]), np.array([reward]), np.array([done or timeout]),
               [{"TimeLimit.truncated": timeout}])
    buffer.adding_demonstrations = False


def add_rows(buffer: QMapReplayBuffer, actions, demonstrations: bool) -> None:
    for action in actions:
        add_step(buffer, action, demo=demonstrations)


def assert_base_actions_free(actions: np.ndarray, masks: np.ndarray) -> int:
    """Every base action lies on an allowed base cell and every arm action on an allowed arm
    cell of its row's (2, Q, Q) masks; returns the number of base actions."""
    base = actions < YAW_BINS * Q * Q
    part = (~base).astype(int)
    cells = np.where(base, actions, actions - YAW_BINS * Q * Q) % (Q * Q)
    assert masks.reshape(len(actions), 2, -1)[np.arange(len(actions)), part, cells].all()
    return int(base.sum())
