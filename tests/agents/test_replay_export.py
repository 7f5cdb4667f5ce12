"""The compact replay file (``export_replay`` / ``import_replay`` / ``read_replay``): a round trip gives
the same buffer (bit for bit; float16 depth of SB3's float32 buffers within float16 precision), only
filled rows are stored, and ``finish_stopped_step`` stores the step SB3 leaves out when a callback
stops training."""

import json
import zipfile

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from stable_baselines3 import DQN, SAC
from stable_baselines3.common.buffers import DictReplayBuffer, ReplayBuffer
from stable_baselines3.common.callbacks import BaseCallback

from relmogen.agents.dqn import QMapReplayBuffer
from relmogen.agents.qmap_network import NUM_MAPS
from relmogen.agents.replay import (CompactDictReplayBuffer, _named_row_arrays, export_replay,
                                    finish_stopped_step, import_replay, read_replay, resize_replay_buffer,
                                    rows_to_keep, stored_rows)

N_ENVS = 2
Q = 4
SPACE = spaces.Dict({"rgb": spaces.Box(0, 255, (3, 8, 8), np.uint8),
                     "depth": spaces.Box(0.0, 3.0, (8, 8, 1), np.float32),
                     "task_obs": spaces.Box(-np.inf, np.inf, (5,), np.float32)})
DICT_BUFFERS = {  # class, action space, constructor arguments
    "sb3-dict": (DictReplayBuffer, spaces.Box(-1, 1, (3,), np.float32), {}),
    "compact": (CompactDictReplayBuffer, spaces.Box(-1, 1, (3,), np.float32), {}),
    "relmogen-d": (QMapReplayBuffer, spaces.Discrete(NUM_MAPS * Q * Q), {"keep_demonstrations": True}),
}


def observation(rng, space=SPACE) -> dict:
    return {key: (rng.integers(0, 256, (N_ENVS, *box.shape)) if box.dtype == np.uint8
                  else rng.uniform(0.0, 3.0, (N_ENVS, *box.shape))).astype(box.dtype)
            for key, box in space.spaces.items()}


def filled(kind: str, capacity: int, steps: int, demonstrations: int = 0, seed: int = 0):
    """A buffer of ``kind`` after ``steps`` vectorised steps of episodes of random length: the next
    observation is the next row's observation except at an episode end (a fresh reset follows)."""
    cls, action_space, kwargs = DICT_BUFFERS[kind]
    buffer = cls(capacity * N_ENVS, SPACE, action_space, n_envs=N_ENVS, **kwargs)
    rng = np.random.default_rng(seed)
    obs = observation(rng)
    for step in range(steps):
        if isinstance(buffer, QMapReplayBuffer):
            buffer.adding_demonstrations = step < demonstrations
            buffer.acting_masks = rng.random((N_ENVS, 2, Q, Q)) < 0.7
        next_obs, done = observation(rng), rng.random(N_ENVS) < 0.2
        infos = [{"TimeLimit.truncated": bool(end and rng.random() < 0.5), "base_mask": rng.random((Q, Q)) < 0.5,
                  "arm_mask": rng.random((Q, Q)) < 0.5} for end in done]
        action = (rng.integers(0, NUM_MAPS * Q * Q, (N_ENVS, 1)) if isinstance(action_space, spaces.Discrete)
                  else rng.uniform(-1, 1, (N_ENVS, 3)).astype(np.float32))
        buffer.add(obs, next_obs, action, rng.standard_normal(N_ENVS).astype(np.float32), done.astype(np.float32),
                   infos)
        reset = observation(rng)
        obs = {key: np.where(done.reshape(-1, *[1] * (array.ndim - 1)), reset[key], array)
               for key, array in next_obs.items()}
    if isinstance(buffer, QMapReplayBuffer):
        buffer.adding_demonstrations = False
        buffer.priorities[: buffer.size()] = rng.random(buffer.priorities[: buffer.size()].shape)
        buffer.max_priority, buffer.n_step_returns, buffer.gamma = 3.5, 3, 0.97
    return buffer


def assert_same_buffer(loaded, original, depth_in_float16: bool = False) -> None:
    assert (loaded.buffer_size, loaded.n_envs, loaded.pos, loaded.full) == \
        (original.buffer_size, original.n_envs, original.pos, original.full)
    ours, theirs = (_named_row_arrays(vars(b), b.buffer_size) for b in (loaded, original))
    assert set(ours) == set(theirs)
    filled = original.buffer_size if original.full else original.pos
    for name, array in theirs.items():  # the filled rows (rows never written are not stored)
        assert ours[name].dtype == array.dtype and ours[name].shape == array.shape, name
        rows = filled + (name == "observations" and original.optimize_memory_usage and not original.full)
        mine, array = ours[name][:rows], array[:rows]
        if depth_in_float16 and name.endswith("/depth"):
            np.testing.assert_allclose(mine, array, rtol=2**-11, atol=0, err_msg=name)  # float16 rounding
            np.testing.assert_array_equal(mine, array.astype(np.float16).astype(np.float32))
        else:
            assert np.array_equal(mine.view(np.uint8), array.view(np.uint8)), name  # bit for bit


def stored_rows_in_file(path, name: str) -> int:
    with np.load(path) as stored:
        return len(stored[f"replay/{name}"])


@pytest.mark.parametrize("kind", DICT_BUFFERS)
@pytest.mark.parametrize("steps", [13, 47])  # part filled; wrapped round the 20-row ring (pos 7)
def test_a_round_trip_gives_the_same_buffer(tmp_path, kind, steps):
    original = filled(kind, 20, steps, demonstrations=3)
    export_replay(original, tmp_path / "replay.npz")
    cls, action_space, kwargs = DICT_BUFFERS[kind]
    loaded = cls(6 * N_ENVS, SPACE, action_space, n_envs=N_ENVS, **kwargs)  # a resumed model's, other capacity
    import_replay(tmp_path / "replay.npz", loaded)
    assert original.full == (steps > 20)
    assert_same_buffer(loaded, original, depth_in_float16=kind == "sb3-dict")
    assert stored_rows_in_file(tmp_path / "replay.npz", "rewards") == min(steps, 20)  # only the filled rows
    if kind == "relmogen-d":
        settings = (loaded.keep_demonstrations, loaded.n_step_returns, loaded.gamma, loaded.max_priority)
        assert settings == (True, 3, 0.97, 3.5)
        assert loaded.demo[:3].all() and not loaded.demo[3:].any()
    loaded.sample(8)
    resize_replay_buffer(loaded, 30 * N_ENVS)  # as a resume does next: every transition kept, in order
    np.testing.assert_array_equal(loaded.rewards[stored_rows(loaded)], original.rewards[rows_to_keep(original, 30)])


def test_sb3_float32_depth_is_stored_as_float16_and_everything_else_at_its_own_dtype(tmp_path):
    export_replay(filled("sb3-dict", 20, 5), tmp_path / "replay.npz")
    with np.load(tmp_path / "replay.npz") as stored:
        assert stored["replay/observations/depth"].dtype == np.float16
        assert stored["replay/observations/rgb"].dtype == np.uint8
        assert stored["replay/observations/task_obs"].dtype == np.float32
        assert stored["replay/actions"].dtype == np.float32


def test_next_observations_found_in_the_row_after_are_not_stored_twice(tmp_path):
    buffer = filled("compact", 40, 30)
    export_replay(buffer, tmp_path / "replay.npz")
    ends = int(buffer.dones[:30].sum())
    explicit = stored_rows_in_file(tmp_path / "replay.npz", "next_observations/rgb")
    assert ends <= explicit <= ends + N_ENVS  # episode ends and the newest row's next observations


def test_an_episode_end_at_the_newest_row_of_a_full_ring_keeps_its_terminal_observation(tmp_path):
    buffer = filled("compact", 10, 10)  # full, pos 0: the row after the newest is the oldest
    buffer.next_observations["rgb"][9] = buffer.observations["rgb"][0]  # equal bytes: taken from there, rightly
    export_replay(buffer, tmp_path / "replay.npz")
    loaded = read_replay(tmp_path / "replay.npz")
    assert_same_buffer(loaded, buffer)


@pytest.mark.parametrize("optimize", [False, True])
@pytest.mark.parametrize("steps", [9, 23])
def test_sb3_array_buffers_round_trip_with_and_without_optimize_memory_usage(tmp_path, optimize, steps):
    space = spaces.Box(-1, 1, (4,), np.float32)
    buffer = ReplayBuffer(10 * N_ENVS, space, spaces.Discrete(3), n_envs=N_ENVS, optimize_memory_usage=optimize,
                          handle_timeout_termination=not optimize)
    rng = np.random.default_rng(1)
    obs = rng.uniform(-1, 1, (N_ENVS, 4)).astype(np.float32)
    for _ in range(steps):
        next_obs = rng.uniform(-1, 1, (N_ENVS, 4)).astype(np.float32)
        buffer.add(obs, next_obs, rng.integers(0, 3, (N_ENVS, 1)), rng.random(N_ENVS), np.zeros(N_ENVS), [{}] * N_ENVS)
        obs = next_obs
    export_replay(buffer, tmp_path / "replay.npz")
    loaded = ReplayBuffer(4, space, spaces.Discrete(3), n_envs=N_ENVS, optimize_memory_usage=optimize,
                          handle_timeout_termination=not optimize)
    import_replay(tmp_path / "replay.npz", loaded)
    if optimize and steps < 10:  # the newest next observation lives in row pos
        np.testing.assert_array_equal(loaded.observations[steps], buffer.observations[steps])
    assert_same_buffer(loaded, buffer)
    assert_same_buffer(read_replay(tmp_path / "replay.npz"), buffer)


def test_read_replay_gives_a_buffer_to_inspect_and_sample_without_a_model(tmp_path):
    buffer = filled("relmogen-d", 20, 15, demonstrations=2)
    export_replay(buffer, tmp_path / "replay.npz")
    loaded = read_replay(tmp_path / "replay.npz")
    assert type(loaded) is QMapReplayBuffer and loaded.size() == 15
    assert_same_buffer(loaded, buffer)
    assert loaded.sample(4).masks.shape == (4, 2, Q, Q)


def test_named_buffers_round_trip_together(tmp_path):
    """HRL4IN's two levels go to one file."""
    high, low = filled("compact", 10, 4, seed=1), filled("compact", 20, 30, seed=2)
    export_replay({"high": high, "low": low}, tmp_path / "replay.npz")
    targets = {name: CompactDictReplayBuffer(2, SPACE, spaces.Box(-1, 1, (3,), np.float32), n_envs=N_ENVS)
               for name in ("high", "low")}
    import_replay(tmp_path / "replay.npz", targets)
    assert_same_buffer(targets["high"], high)
    assert_same_buffer(targets["low"], low)
    assert set(read_replay(tmp_path / "replay.npz")) == {"high", "low"}
    with pytest.raises(ValueError, match="holds the replay buffers"):
        import_replay(tmp_path / "replay.npz", targets["low"])


def test_a_buffer_of_other_observation_shapes_is_refused_and_left_as_it_was(tmp_path):
    export_replay(filled("compact", 10, 4), tmp_path / "replay.npz")
    space = spaces.Dict({**SPACE.spaces, "rgb": spaces.Box(0, 255, (3, 16, 16), np.uint8)})
    other = CompactDictReplayBuffer(8, space, spaces.Box(-1, 1, (3,), np.float32), n_envs=N_ENVS)
    with pytest.raises(ValueError, match="observations/rgb is \\(3, 8, 8\\) per transition"):
        import_replay(tmp_path / "replay.npz", other)
    assert other.buffer_size == 4 and other.pos == 0


def test_an_array_the_file_lacks_is_rebuilt_by_the_buffers_upgrade(tmp_path):
    """A compact file of a buffer written before an add-on's array (here ``labels``) loads as an
    older pickle does: ``upgraded_state`` fills it in."""
    buffer = filled("relmogen-d", 10, 6, demonstrations=2)
    export_replay(buffer, tmp_path / "full.npz")
    with zipfile.ZipFile(tmp_path / "full.npz") as source, zipfile.ZipFile(tmp_path / "old.npz", "w") as target:
        for item in source.infolist():
            data = source.read(item)
            if item.filename == "meta.json":
                meta = json.loads(data)
                del meta["buffers"]["replay"]["arrays"]["labels"]
                data = json.dumps(meta).encode()
            if item.filename != "replay/labels.npy":
                target.writestr(item, data)
    loaded = DICT_BUFFERS["relmogen-d"][0](8, SPACE, DICT_BUFFERS["relmogen-d"][1], n_envs=N_ENVS)
    import_replay(tmp_path / "old.npz", loaded)
    np.testing.assert_array_equal(loaded.labels[:2], buffer.actions[:2, :, 0])  # demonstrations: their own actions
    assert (loaded.labels[2:] == -1).all()


# ------------------------------------------------------------------ the step SB3 leaves out
class StopAfter(BaseCallback):
    def __init__(self, steps: int, finish: bool):
        super().__init__()
        self.steps, self.finish = steps, finish

    def _on_step(self) -> bool:
        if self.n_calls < self.steps:
            return True
        new_obs, info = self.locals["new_obs"], self.locals["infos"][0]
        self.last_next_obs = info.get("terminal_observation", new_obs[0])
        if self.finish:
            finish_stopped_step(self.model, self.locals)
        return False


@pytest.mark.parametrize("algo", [SAC, DQN])
@pytest.mark.parametrize("finish", [False, True])
def test_a_callback_that_stops_training_stores_the_last_step_with_finish_stopped_step(algo, finish):
    env = gym.make("Pendulum-v1" if algo is SAC else "CartPole-v1")
    model = algo("MlpPolicy", env, buffer_size=100, learning_starts=1000, seed=0)
    callback = StopAfter(7, finish)
    model.learn(total_timesteps=10**6, callback=callback)
    assert model.num_timesteps == 7
    assert model.replay_buffer.size() == (7 if finish else 6)  # SB3 alone stores the step after the callback
    if finish:
        np.testing.assert_array_equal(model.replay_buffer.next_observations[6, 0], callback.last_next_obs)
    if algo is DQN:  # the step's bookkeeping too (target update counter)
        assert model._n_calls == (7 if finish else 6)
    env.close()
