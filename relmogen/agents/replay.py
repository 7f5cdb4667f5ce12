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

``export_replay`` / ``import_replay`` move a buffer through a compact file that does not depend on
the Python classes pickled with it (``replay.npz``, see ``export_replay``); ``read_replay`` reads
one without a model, for inspection. ``finish_stopped_step`` stores the step SB3 leaves out of the
replay when a callback stops training.
"""

from __future__ import annotations

import importlib
import json
import zipfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.buffers import BaseBuffer, DictReplayBuffer, ReplayBuffer
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


# ------------------------------------------------------------------ compact export
REPLAY_FORMAT = "relmogen-replay"
REPLAY_FORMAT_VERSION = 1
META_NAME = "meta.json"
DEFAULT_BUFFER = "replay"  # the name of a model's single buffer in the file; HRL4IN's are "high" and "low"
COMPRESS_LEVEL = 1  # zlib level. 2,000 PushDoorNav transitions at 64 px: relmogen-d 127 MB pickled, 8.1 MB here
# (6.1 MB at level 6, 1.5x the time); relmogen-r 86 MB, 6.2 MB (5.2 MB at 6, 2x the time)
FOLLOWING = "next_is_following"  # (rows, n_envs) bool: the next observation is the row after's observation
_CHUNK_BYTES = 64 * 2**20  # rows compared or copied at a time: temporaries stay well below the buffer


def export_replay(buffers: BaseBuffer | Mapping[str, BaseBuffer], path: Path | str,
                  level: int = COMPRESS_LEVEL) -> Path:
    """Write a replay buffer (or named buffers, as HRL4IN's ``high`` and ``low``) as a compact file.

    The file is a zip of ``.npy`` arrays (``numpy.load`` opens it) and ``meta.json``, deflated at
    ``level``. Only the filled rows are stored (all rows of a full ring, with ``pos`` kept),
    every array at its own dtype (uint8 images, float16 depth of ``CompactDictReplayBuffer``,
    float32 vectors, bool masks, ...), except ``HALF_PRECISION_KEYS`` observations stored wider
    than float16 (SB3's own buffers), which are written as float16. A next observation equal, byte
    for byte, to the observation of the row after it (the same environment's next step: all but
    episode ends and the newest row) is not written again: ``next_is_following`` marks it and
    ``import_replay`` copies it back. The buffer's scalar attributes (``pos``, ``full``,
    ``buffer_size``, ``n_envs``, the add-ons' settings, ...) go to ``meta.json``."""
    path = Path(path)
    meta = {"format": REPLAY_FORMAT, "version": REPLAY_FORMAT_VERSION, "buffers": {}}
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=level, allowZip64=True) as archive:
        for name, buffer in _named_buffers(buffers).items():
            meta["buffers"][name] = _export_buffer(archive, name, buffer)
        archive.writestr(META_NAME, json.dumps(meta, indent=1))
    return path


def import_replay(path: Path | str, buffers: BaseBuffer | Mapping[str, BaseBuffer]) -> None:
    """Load an ``export_replay`` file into existing buffers (a model's, built with its spaces and
    device), in place. Each becomes the saved one as a pickle would make it: the saved capacity,
    ``n_envs``, ``pos``, ``full`` and scalar attributes, its arrays at the buffer's own dtypes
    (float16 depth back to float32 in SB3's buffers); the device, spaces and other objects stay
    the buffer's. An array the buffer has and the file lacks is rebuilt by the buffer's
    ``upgraded_state`` when it has one (as for older pickles), else it is an error, as are
    observations or masks of other shapes."""
    targets = _named_buffers(buffers)
    with zipfile.ZipFile(path) as archive:
        meta = _read_meta(archive, path)
        if set(targets) != set(meta["buffers"]):
            raise ValueError(f"{path} holds the replay buffers {sorted(meta['buffers'])}, not {sorted(targets)}")
        states = {name: _imported_state(archive, name, meta["buffers"][name], buffer)
                  for name, buffer in targets.items()}
    for name, buffer in targets.items():  # only once every buffer was read without error
        buffer.__dict__.clear()
        buffer.__dict__.update(states[name])


def read_replay(path: Path | str) -> BaseBuffer | dict[str, BaseBuffer]:
    """The buffer(s) of an ``export_replay`` file without a model, for inspection (rows, flags,
    arrays; ``sample`` on the CPU): rebuilt from the class named in the file, at full capacity,
    with observation shapes from the arrays and no spaces. A file of one model buffer gives the
    buffer, HRL4IN's gives ``{"high": ..., "low": ...}``."""
    with zipfile.ZipFile(path) as archive:
        meta = _read_meta(archive, path)
        buffers = {}
        for name, saved in meta["buffers"].items():
            module, _, qualname = saved["class"].rpartition(".")
            cls = getattr(importlib.import_module(module), qualname)
            buffer = cls.__new__(cls)
            state = _imported_state(archive, name, saved, None)
            state.update(device=th.device("cpu"), observation_space=None, action_space=None,
                         action_dim=int(state["actions"].shape[-1]))
            observations = state["observations"]
            state["obs_shape"] = ({key: array.shape[2:] for key, array in observations.items()}
                                  if isinstance(observations, dict) else observations.shape[2:])
            buffer.__dict__.update(state)
            buffers[name] = buffer
    return buffers[DEFAULT_BUFFER] if list(buffers) == [DEFAULT_BUFFER] else buffers


def _named_buffers(buffers: BaseBuffer | Mapping[str, BaseBuffer]) -> dict[str, BaseBuffer]:
    return {DEFAULT_BUFFER: buffers} if isinstance(buffers, BaseBuffer) else dict(buffers)


def _read_meta(archive: zipfile.ZipFile, path) -> dict:
    try:
        meta = json.loads(archive.read(META_NAME))
    except KeyError:
        raise ValueError(f"{path} is not a relmogen replay file (no {META_NAME})") from None
    if meta.get("format") != REPLAY_FORMAT or meta.get("version", 0) > REPLAY_FORMAT_VERSION:
        raise ValueError(f"{path}: replay format {meta.get('format')} version {meta.get('version')} is not "
                         f"{REPLAY_FORMAT} up to version {REPLAY_FORMAT_VERSION}")
    return meta


def _array_name(parent: str | None, key: str) -> str:
    return key if parent is None else f"{parent}/{key}"


def _named_row_arrays(buffer_state: dict, rows: int) -> dict[str, np.ndarray]:
    """name (``actions``, ``observations/rgb``, ...) -> array, for every row array of a buffer."""
    return {_array_name(parent, key): _container(buffer_state, parent)[key]
            for parent, key in _row_arrays(buffer_state, rows)}


def _scalar_attributes(buffer_state: dict) -> dict:
    """The attributes JSON holds exactly: flags, counters, settings (None included)."""
    scalars = {}
    for key, value in buffer_state.items():
        if isinstance(value, np.generic):
            value = value.item()
        if value is None or isinstance(value, (bool, int, float, str)):
            scalars[key] = value
    return scalars


def _next_pairs(arrays: dict[str, np.ndarray]) -> list[tuple[str, str]]:
    """(next observation array, observation array) names: ``next_observations[/key]`` and its partner."""
    pairs = [(name, name.replace("next_observations", "observations", 1)) for name in arrays
             if name.split("/")[0] == "next_observations"]
    return [(next_name, name) for next_name, name in pairs if name in arrays]


def _chunks(rows: int, array: np.ndarray) -> Iterator[slice]:
    step = max(1, _CHUNK_BYTES // max(1, array[:1].nbytes))
    for start in range(0, rows, step):
        yield slice(start, min(start + step, rows))


def _following_rows(rows: np.ndarray, capacity: int) -> np.ndarray:
    return (rows + 1) % capacity


def _next_is_following(arrays: dict[str, np.ndarray], pairs: list[tuple[str, str]], filled: int, capacity: int,
                       full: bool, n_envs: int) -> np.ndarray:
    """(filled, n_envs) bool: every next observation of the row equals, byte for byte, the row after's
    observation, for every key (so the row after is the same environment's next step)."""
    same = np.ones((filled, n_envs), dtype=bool)
    if not full:  # the newest row has no row after it yet
        same[filled - 1:] = False
    for next_name, name in pairs:
        nexts, observations = arrays[next_name], arrays[name]
        for rows in _chunks(filled, nexts):
            index = np.arange(rows.start, rows.stop)
            after = observations[_following_rows(index, capacity)].reshape(len(index), n_envs, -1)
            own = np.ascontiguousarray(nexts[rows]).reshape(len(index), n_envs, -1)
            same[rows] &= (own.view(np.uint8) == after.view(np.uint8)).all(axis=2) if own.size else True
    return same


def _write_array(archive: zipfile.ZipFile, name: str, array: np.ndarray) -> None:
    with archive.open(f"{name}.npy", "w", force_zip64=True) as handle:
        np.lib.format.write_array(handle, np.ascontiguousarray(array), allow_pickle=False)


def _export_buffer(archive: zipfile.ZipFile, prefix: str, buffer: BaseBuffer) -> dict:
    state = vars(buffer)
    capacity, n_envs = buffer.buffer_size, buffer.n_envs
    filled = capacity if buffer.full else buffer.pos
    arrays = _named_row_arrays(state, capacity)
    pairs = _next_pairs(arrays) if filled else []
    following = _next_is_following(arrays, pairs, filled, capacity, buffer.full, n_envs) if pairs else None
    saved = {"class": f"{type(buffer).__module__}.{type(buffer).__qualname__}", "attributes": _scalar_attributes(state),
             "arrays": {}, "deduplicated": [next_name for next_name, _ in pairs]}
    for name, array in arrays.items():
        rows = filled
        if name == "observations" and getattr(buffer, "optimize_memory_usage", False) and not buffer.full and filled:
            rows = filled + 1  # SB3's memory-saving ReplayBuffer keeps the newest next observation in row pos
        part = array[:rows]
        if following is not None and name in saved["deduplicated"]:
            part = part[~following]  # (k, *shape): only the next observations not found in the row after
        if name.split("/")[-1] in HALF_PRECISION_KEYS and name.split("/")[0] in ("observations", "next_observations") \
                and np.issubdtype(part.dtype, np.floating) and part.dtype.itemsize > 2:
            part = part.astype(np.float16)
        _write_array(archive, f"{prefix}/{name}", part)
        saved["arrays"][name] = {"dtype": array.dtype.str, "shape": list(array.shape[1:]), "rows": rows}
    if following is not None:
        _write_array(archive, f"{prefix}/{FOLLOWING}", following)
    return saved


def _load_array(archive: zipfile.ZipFile, name: str) -> np.ndarray:
    with archive.open(f"{name}.npy") as handle:
        return np.lib.format.read_array(handle, allow_pickle=False)


def _read_header(handle) -> tuple[tuple[int, ...], np.dtype]:
    version = np.lib.format.read_magic(handle)
    read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
    shape, fortran_order, dtype = read(handle)
    if fortran_order or dtype.hasobject:
        raise ValueError("a replay array must be C-ordered plain data")
    return shape, dtype


def _read_rows_into(archive: zipfile.ZipFile, name: str, array: np.ndarray) -> None:
    """The stored rows of ``name`` straight into the first rows of ``array`` (converted to its
    dtype one chunk at a time when they differ), without a second full copy."""
    with archive.open(f"{name}.npy") as handle:
        shape, dtype = _read_header(handle)
        if tuple(shape[1:]) != array.shape[1:] or shape[0] > len(array):
            raise ValueError(f"replay array {name} is {shape}, expected up to {array.shape}")
        rows = array[: shape[0]]
        if dtype == array.dtype:
            _read_exactly(handle, rows.reshape(-1).view(np.uint8), name)
            return
        for chunk in _chunks(shape[0], rows):
            stored = np.empty((chunk.stop - chunk.start, *shape[1:]), dtype=dtype)
            _read_exactly(handle, stored.reshape(-1).view(np.uint8), name)
            rows[chunk] = stored


def _read_exactly(handle, target: np.ndarray, name: str) -> None:
    done, view = 0, memoryview(target)
    while done < len(view):
        count = handle.readinto(view[done: done + _CHUNK_BYTES])
        if not count:
            raise ValueError(f"replay array {name} is cut short (file not fully written?)")
        done += count


def _imported_state(archive: zipfile.ZipFile, prefix: str, saved: dict, buffer: BaseBuffer | None) -> dict:
    """The ``__dict__`` the buffer gets: its own objects, the saved scalars, and the saved arrays at
    the saved capacity (and at the buffer's dtypes)."""
    attributes = saved["attributes"]
    capacity, n_envs = int(attributes["buffer_size"]), int(attributes["n_envs"])
    own = {} if buffer is None else dict(vars(buffer))
    targets = {} if buffer is None else _named_row_arrays(own, buffer.buffer_size)
    for name in targets:  # the buffer's row arrays are replaced, not kept at their old capacity
        parent, _, key = name.rpartition("/")
        if parent:
            own[parent] = {k: v for k, v in own[parent].items() if k != key}
        else:
            own.pop(key)
    state = {**own, **attributes}
    arrays: dict[str, np.ndarray] = {}
    for name, info in saved["arrays"].items():
        target = targets.get(name)
        dtype = target.dtype if target is not None else np.dtype(info["dtype"])
        if target is not None and tuple(target.shape[2:]) != tuple(info["shape"][1:]):
            raise ValueError(f"the saved replay's {prefix} {name} is {tuple(info['shape'][1:])} per transition, "
                             f"this model's {tuple(target.shape[2:])}: was the run's environment changed?")
        arrays[name] = np.zeros((capacity, *info["shape"]), dtype=dtype)
        if name not in saved["deduplicated"]:
            _read_rows_into(archive, f"{prefix}/{name}", arrays[name])
    following = None
    if saved["deduplicated"]:
        filled = capacity if attributes["full"] else int(attributes["pos"])
        following = _load_array(archive, f"{prefix}/{FOLLOWING}")
    for next_name in saved["deduplicated"]:
        _refill_next(arrays[next_name], arrays[next_name.replace("next_observations", "observations", 1)],
                     _load_array(archive, f"{prefix}/{next_name}"), following, filled, bool(attributes["full"]))
    for name, array in arrays.items():
        parent, _, key = name.rpartition("/")
        if parent:
            state[parent] = {**(state.get(parent) or {}), key: array}
        else:
            state[key] = array
    if buffer is not None and hasattr(buffer, "upgraded_state"):
        state = buffer.upgraded_state(state)  # arrays added after the file was written (older buffers)
    missing = [name for name in targets if name not in _named_row_arrays(state, capacity)]
    if missing:
        raise ValueError(f"the saved replay's {prefix} buffer has no {', '.join(missing)} (a {saved['class']}); "
                         f"this model's {type(buffer).__name__} needs them")
    return state


def _refill_next(nexts: np.ndarray, observations: np.ndarray, explicit: np.ndarray, following: np.ndarray,
                 filled: int, full: bool) -> None:
    """Rebuild a deduplicated next-observation array: every row gets the observation of the row after
    it (the oldest row, after the newest of a full ring), then the explicitly stored ones replace
    those not ``following``."""
    if filled > 1:
        nexts[: filled - 1] = observations[1:filled]
    if full:
        nexts[filled - 1] = observations[0]
    nexts[:filled][~following] = explicit


# ------------------------------------------------------------ SB3's unstored step
def finish_stopped_step(model, rollout_locals: dict) -> None:
    """Do what SB3's ``collect_rollouts`` leaves undone when a callback's ``on_step`` returns False:
    it returns before storing that step's transition (``_store_transition`` comes after
    ``callback.on_step``), so a replay saved at the end would lack the step that ended training,
    usually the last episode's final transition. Call it from ``_on_step`` just before returning
    False, with the callback's ``self.locals``; it stores the transition and finishes the step's
    bookkeeping as SB3 would have. A no-op for loops that store before the callback (HRL4IN's
    passes only ``infos`` and ``dones``)."""
    needed = ("replay_buffer", "buffer_actions", "new_obs", "rewards", "dones", "infos")
    if not all(key in rollout_locals for key in needed):
        return
    infos, dones = rollout_locals["infos"], rollout_locals["dones"]
    model._update_info_buffer(infos, dones)
    model._store_transition(rollout_locals["replay_buffer"], rollout_locals["buffer_actions"],
                            rollout_locals["new_obs"], rollout_locals["rewards"], dones, infos)
    model._update_current_progress_remaining(model.num_timesteps, model._total_timesteps)
    model._on_step()
    model._episode_num += int(np.sum(dones))
    noise = rollout_locals.get("action_noise")
    for index, done in enumerate(dones):
        if done and noise is not None:
            noise.reset(**(dict(indices=[index]) if len(dones) > 1 else {}))
