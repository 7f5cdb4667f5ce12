"""Resizing a loaded replay buffer keeps the newest transitions in time order, and every kept demonstration."""

import pickle

import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import DictReplayBuffer, ReplayBuffer

from relmogen.agents.dqn import QMapReplayBuffer
from relmogen.agents.qmap_network import NUM_MAPS
from relmogen.agents.replay import CompactDictReplayBuffer, resize_replay_buffer, stored_rows

N_ENVS = 2


def filled(buffer_cls, observation_space, transitions: int, steps: int):
    buffer = buffer_cls(transitions, observation_space, spaces.Discrete(5), n_envs=N_ENVS)
    for step in range(steps):  # observation and reward of step t are both t
        obs = ({key: np.full((N_ENVS, 3), step, np.float32) for key in observation_space.spaces}
               if isinstance(observation_space, spaces.Dict) else np.full((N_ENVS, 3), step, np.float32))
        buffer.add(obs, obs, np.zeros((N_ENVS, 1)), np.full(N_ENVS, step, np.float32), np.zeros(N_ENVS),
                   [{}] * N_ENVS)
    return buffer


def stored_steps(buffer) -> list[int]:
    return [int(buffer.rewards[row, 0]) for row in stored_rows(buffer)]


@pytest.mark.parametrize("steps", [3, 7])  # not yet full / wrapped around the ring
def test_growing_keeps_every_transition_in_order_and_appends_after_them(steps):
    buffer = filled(ReplayBuffer, spaces.Box(-1, 1, (3,)), transitions=10, steps=steps)
    before = stored_steps(buffer)
    resize_replay_buffer(buffer, 40)
    assert buffer.buffer_size == 20 and buffer.observations.shape[0] == 20 and not buffer.full
    assert stored_steps(buffer) == before == list(range(max(0, steps - 5), steps))
    assert np.array_equal(buffer.observations[stored_rows(buffer), 0, 0], before)
    buffer.add(np.zeros((N_ENVS, 3)), np.zeros((N_ENVS, 3)), np.zeros((N_ENVS, 1)), np.full(N_ENVS, 99.0),
               np.zeros(N_ENVS), [{}] * N_ENVS)
    assert stored_steps(buffer) == before + [99]


def test_shrinking_a_dict_buffer_keeps_the_newest_rows_of_every_array():
    space = spaces.Dict({"rgb": spaces.Box(-1, 1, (3,)), "depth": spaces.Box(-1, 1, (3,))})
    buffer = filled(DictReplayBuffer, space, transitions=10, steps=8)
    resize_replay_buffer(buffer, 6)
    assert buffer.buffer_size == 3 and buffer.full and buffer.pos == 0
    assert stored_steps(buffer) == [5, 6, 7]
    for store in (buffer.observations, buffer.next_observations):
        assert all(np.array_equal(array[:, 0, 0], [5, 6, 7]) for array in store.values())
    assert buffer.sample(4).rewards.shape == (4, 1)


def demonstration_buffer(rows: int) -> QMapReplayBuffer:
    """A kept-demonstrations buffer: 3 demonstration rows (actions 20-22), then policy rows 0-9."""
    space = spaces.Dict({"depth": spaces.Box(0.0, 3.0, (2, 2, 1), np.float32)})
    buffer = QMapReplayBuffer(rows, space, spaces.Discrete(NUM_MAPS), device="cpu", keep_demonstrations=True)
    obs = {"depth": np.zeros((1, 2, 2, 1), np.float32)}
    for action, demonstration in [(20, True), (21, True), (22, True), *((a, False) for a in range(10))]:
        buffer.adding_demonstrations = demonstration
        buffer.add(obs, obs, np.array([[action]]), np.zeros(1), np.zeros(1), [{}])
    buffer.adding_demonstrations = False
    return buffer


def test_shrinking_keeps_every_kept_demonstration_and_the_newest_policy_rows():
    buffer = demonstration_buffer(8)
    resize_replay_buffer(buffer, 5)
    assert buffer.actions[:, 0, 0].tolist() == [20, 21, 22, 8, 9] and buffer.demo.tolist() == [True] * 3 + [False] * 2
    with pytest.raises(ValueError, match="3 kept demonstration rows do not leave room in 3 rows"):
        resize_replay_buffer(demonstration_buffer(8), 3)


def sgpr_space(size: int = 64) -> spaces.Dict:
    return spaces.Dict({
        "rgb": spaces.Box(0, 255, (size, size, 3), np.uint8),
        "depth": spaces.Box(0.0, 3.0, (size, size, 1), np.float32),
        "scan": spaces.Box(0.0, 1.0, (220,), np.float32),
        "task_obs": spaces.Box(-np.inf, np.inf, (55,), np.float32),
    })


def test_compact_replay_stores_depth_as_float16_and_samples_float32():
    buffer = CompactDictReplayBuffer(10, sgpr_space(8), spaces.Box(-1, 1, (8,)), n_envs=1)
    obs = {key: np.full((1, *space.shape), 1.2345, space.dtype) for key, space in sgpr_space(8).spaces.items()}
    buffer.add(obs, obs, np.zeros((1, 8)), np.zeros(1), np.zeros(1), [{}])
    assert buffer.observations["depth"].dtype == buffer.next_observations["depth"].dtype == np.float16
    assert buffer.observations["rgb"].dtype == np.uint8 and buffer.observations["scan"].dtype == np.float32
    sample = buffer.sample(4)
    assert sample.observations["depth"].dtype == th.float32
    assert float(sample.observations["depth"].max()) == pytest.approx(1.2345, abs=2e-3)  # float16 step at 3 m


def test_a_1e5_sgpr_replay_at_64_px_takes_about_4_gb():
    buffer = CompactDictReplayBuffer(10_000, sgpr_space(64), spaces.Box(-1, 1, (8,)), n_envs=2)
    per_1e4 = buffer.nbytes() / 2**30
    # state + next state: rgb 12,288 B + float16 depth 8,192 B + scan 880 B + task 220 B, twice
    assert 0.39 < per_1e4 < 0.42
    assert 10 * per_1e4 < 4.2


def test_a_partly_filled_replay_pickles_only_its_filled_rows_and_loads_at_full_capacity():
    buffer = CompactDictReplayBuffer(2_000, sgpr_space(16), spaces.Box(-1, 1, (8,)), n_envs=1)
    for step in range(5):
        obs = {key: np.full((1, *space.shape), step, space.dtype) for key, space in sgpr_space(16).spaces.items()}
        buffer.add(obs, obs, np.zeros((1, 8)), np.full(1, step, np.float32), np.zeros(1), [{}])
    data = pickle.dumps(buffer)
    assert len(data) < 0.01 * buffer.nbytes()
    loaded = pickle.loads(data)
    assert loaded.observations["rgb"].shape == buffer.observations["rgb"].shape
    assert loaded.pos == 5 and not loaded.full and loaded.rewards[:5, 0].tolist() == [0, 1, 2, 3, 4]
    assert loaded.observations["depth"].dtype == np.float16 and loaded.next_observations["depth"][4].max() == 4
