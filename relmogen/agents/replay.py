"""Replay-buffer surgery for resumed runs: give a loaded SB3 buffer a new capacity.

SB3 buffers hold one row per vectorised step (``buffer_size // n_envs`` rows, each with one
transition per environment), written in a ring at ``pos``. Resizing keeps the newest rows in
time order, so a bigger buffer keeps everything and a smaller one drops the oldest. Kept
demonstration rows (relmogen-d's ``algo.demo_keep``) are never dropped.
"""

from __future__ import annotations

import numpy as np
from stable_baselines3.common.buffers import ReplayBuffer


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

    for name, value in vars(buffer).items():
        if isinstance(value, np.ndarray) and value.ndim and value.shape[0] == old_rows:
            setattr(buffer, name, resized(value))
        elif isinstance(value, dict):
            for key, array in value.items():
                if isinstance(array, np.ndarray) and array.shape[0] == old_rows:
                    value[key] = resized(array)
    buffer.buffer_size = rows
    buffer.pos = len(keep) % rows
    buffer.full = len(keep) == rows
