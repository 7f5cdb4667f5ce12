"""Compact replay storage, and replay-buffer surgery for resumed runs.

``CompactDictReplayBuffer`` is SB3's ``DictReplayBuffer`` with ``depth`` stored as float16
(metres up to 3.0: steps of at most 2 mm) and returned as float32; RGB and local maps stay
uint8 as the observation space has them. At 64 px one SGP-R transition (state and next state)
takes about 43 kB, so 1e5 transitions fit in about 4.3 GB.

``resize_replay_buffer`` gives a loaded SB3 buffer a new capacity.

SB3 buffers hold one row per vectorised step (``buffer_size // n_envs`` rows, each with one
transition per environment), written in a ring at ``pos``. Resizing keeps the newest rows in
time order, so a bigger buffer keeps everything and a smaller one drops the oldest. Kept
demonstration rows (relmogen-d's ``algo.demo_keep``) are never dropped.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.buffers import DictReplayBuffer, ReplayBuffer
from stable_baselines3.common.type_aliases import DictReplayBufferSamples, TensorDict

HALF_PRECISION_KEYS = ("depth",)


class CompactDictReplayBuffer(DictReplayBuffer):
    """``DictReplayBuffer`` storing the ``HALF_PRECISION_KEYS`` observations as float16."""

    def __init__(self, buffer_size: int, observation_space: spaces.Dict, *args: Any, **kwargs: Any):
        super().__init__(buffer_size, observation_space, *args, **kwargs)
        for store in (self.observations, self.next_observations):
            for key in HALF_PRECISION_KEYS:
                if key in store:
                    store[key] = np.zeros(store[key].shape, dtype=np.float16)

    def nbytes(self) -> int:
        """Bytes held by the stored arrays."""
        arrays = [*self.observations.values(), *self.next_observations.values(), self.actions, self.rewards,
                  self.dones, self.timeouts]
        return int(sum(array.nbytes for array in arrays))

    def __getstate__(self) -> dict:
        """A buffer that is not full pickles only its filled rows (SB3 pickles the whole capacity)."""
        return self.__dict__.copy() if self.full else filled_rows_only(self.__dict__, self.buffer_size, self.pos)

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(with_full_capacity(state))

    def _batch(self, store: dict[str, np.ndarray], rows, envs, env) -> TensorDict:
        obs = self._normalize_obs({key: array[rows, envs] for key, array in store.items()}, env)
        return {key: self.to_torch(value.astype(np.float32) if value.dtype == np.float16 else value)
                for key, value in obs.items()}

    def _get_samples(self, batch_inds: np.ndarray, env=None) -> DictReplayBufferSamples:
        envs = np.random.randint(0, high=self.n_envs, size=(len(batch_inds),))
        dones = self.dones[batch_inds, envs] * (1 - self.timeouts[batch_inds, envs])
        return DictReplayBufferSamples(
            observations=self._batch(self.observations, batch_inds, envs, env),
            actions=self.to_torch(self.actions[batch_inds, envs]),
            next_observations=self._batch(self.next_observations, batch_inds, envs, env),
            dones=self.to_torch(dones).reshape(-1, 1),
            rewards=self.to_torch(self._normalize_reward(self.rewards[batch_inds, envs].reshape(-1, 1), env)),
        )


def _row_arrays(state: dict, rows: int):
    """(parent key or None, key) of every array in ``state`` (or in its dicts) with ``rows`` rows."""
    def is_rows(value) -> bool:
        return isinstance(value, np.ndarray) and value.ndim > 0 and value.shape[0] == rows

    for key, value in state.items():
        if is_rows(value):
            yield None, key
        elif isinstance(value, dict):
            yield from ((key, name) for name, array in value.items() if is_rows(array))


def _container(state: dict, parent: str | None) -> dict:
    return state if parent is None else state[parent]


def filled_rows_only(state: dict, capacity: int, filled: int) -> dict:
    """A copy of a buffer's ``__dict__`` with its row arrays cut to the first ``filled`` rows."""
    state = {key: dict(value) if isinstance(value, dict) else value for key, value in state.items()}
    trimmed = list(_row_arrays(state, capacity))
    for parent, key in trimmed:
        _container(state, parent)[key] = _container(state, parent)[key][:filled]
    return {**state, "_trimmed_to": filled, "_trimmed": trimmed}


def with_full_capacity(state: dict) -> dict:
    """Undo ``filled_rows_only``: the cut arrays padded back to ``buffer_size`` rows."""
    if "_trimmed" not in state:
        return state
    state = dict(state)
    filled, trimmed = state.pop("_trimmed_to"), state.pop("_trimmed")
    for parent, key in trimmed:
        array = _container(state, parent)[key]
        full = np.zeros((state["buffer_size"], *array.shape[1:]), dtype=array.dtype)
        full[:filled] = array
        _container(state, parent)[key] = full
    return state


def stored_rows(buffer: ReplayBuffer) -> np.ndarray:
    """Indices of the filled rows, oldest first."""
    if not buffer.full:
        return np.arange(buffer.pos)
    return np.roll(np.arange(buffer.buffer_size), -buffer.pos)


def rows_to_keep(buffer: ReplayBuffer, rows: int) -> np.ndarray:
    """The newest ``rows`` filled rows; kept demonstrations (``QMapReplayBuffer.keep_demonstrations``)
    come first and are never dropped."""
    stored = stored_rows(buffer)
    if not getattr(buffer, "keep_demonstrations", False):
        return stored[-rows:]
    demo = buffer.demo[stored]
    if demo.sum() >= rows:
        raise ValueError(f"{int(demo.sum())} kept demonstration rows do not leave room in {rows} rows: "
                         "choose a larger algo.buffer_size")
    others = stored[~demo]
    return np.concatenate([stored[demo], others[max(len(others) - (rows - int(demo.sum())), 0):]])


def resize_replay_buffer(buffer: ReplayBuffer, transitions: int) -> None:
    """In place: capacity ``transitions`` (as ``buffer_size`` is given to SB3: all environments together)."""
    rows = max(transitions // buffer.n_envs, 1)
    old_rows = buffer.buffer_size
    if rows == old_rows:
        return
    keep = rows_to_keep(buffer, rows)

    def resized(array: np.ndarray) -> np.ndarray:
        fresh = np.zeros((rows, *array.shape[1:]), dtype=array.dtype)
        fresh[: len(keep)] = array[keep]
        return fresh

    state = vars(buffer)
    for parent, key in list(_row_arrays(state, old_rows)):
        _container(state, parent)[key] = resized(_container(state, parent)[key])
    buffer.buffer_size = rows
    buffer.pos = len(keep) % rows
    buffer.full = len(keep) == rows
