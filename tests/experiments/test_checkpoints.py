"""The replay in a run's checkpoints: ``write_checkpoint`` writes the compact ``replay.npz``, and runs
saved before it (``replay_buffer.pkl``, in its own folder or inside the model checkpoint) are still
found by ``latest_replay`` and loaded by ``load_replay`` into the same buffer."""

import numpy as np
import pytest
import torch as th

from relmogen.agents.replay import _named_row_arrays
from relmogen.experiments.checkpoints import (CHECKPOINTS, LATEST_REPLAY, PICKLED_REPLAY_FILE, REPLAY_FILE,
                                              _write_folder, latest_replay, load_replay, read_replay_file,
                                              replay_buffers, save_replay, write_checkpoint)
from relmogen.experiments.config import resolve_config
from relmogen.experiments.environments import make_training_env
from relmogen.experiments.models import build_model

TRANSITIONS = 20  # the ring; 25 steps are collected, so it has wrapped round (pos 5)


@pytest.fixture(scope="module")
def one_torch_thread():
    threads = th.get_num_threads()
    th.set_num_threads(1)
    yield
    th.set_num_threads(threads)


@pytest.fixture(scope="module", params=["relmogen-r", "relmogen-d"])
def collected(request, one_torch_thread):
    """A tiny PointNav model after 25 real environment steps (no updates) and a builder of fresh
    models of the same run, as a resume makes them."""
    config = resolve_config("PointNav", request.param, preset="tiny", episodes=1,
                            overrides=["algo.learning_starts=1000000", f"algo.buffer_size={TRANSITIONS}"])
    env = make_training_env(config)
    model = build_model(config, env)
    model.learn(total_timesteps=25)
    yield model, lambda: build_model(config, env)
    env.close()


def assert_same_replay(loaded, original) -> None:
    assert (loaded.buffer_size, loaded.n_envs, loaded.pos, loaded.full) == \
        (original.buffer_size, original.n_envs, original.pos, original.full)
    rows = original.buffer_size if original.full else original.pos
    ours, theirs = (_named_row_arrays(vars(b), b.buffer_size) for b in (loaded, original))
    assert set(ours) == set(theirs)
    for name, array in theirs.items():
        assert ours[name].dtype == array.dtype, name
        assert np.array_equal(ours[name][:rows].view(np.uint8), array[:rows].view(np.uint8)), name


def test_write_checkpoint_saves_a_compact_replay_that_loads_as_the_pickle_does(tmp_path, collected):
    model, fresh = collected
    buffer = model.replay_buffer
    assert buffer.full and buffer.pos == 5 and buffer.observations["rgb"].dtype == np.uint8
    write_checkpoint(tmp_path, model, {"episodes": 2, "timesteps": 25})
    compact = latest_replay(tmp_path)
    assert compact.name == REPLAY_FILE and compact.parent.name == "replay_0000002"
    model.save_replay_buffer(tmp_path / PICKLED_REPLAY_FILE)
    from_compact, from_pickle = fresh(), fresh()
    load_replay(from_compact, compact)
    load_replay(from_pickle, tmp_path / PICKLED_REPLAY_FILE)
    assert_same_replay(from_compact.replay_buffer, buffer)
    assert_same_replay(from_compact.replay_buffer, from_pickle.replay_buffer)
    assert from_compact.replay_buffer.device == from_compact.device
    assert compact.stat().st_size < (tmp_path / PICKLED_REPLAY_FILE).stat().st_size / 4
    from_compact.replay_buffer.sample(4)
    assert_same_replay(read_replay_file(compact), buffer)
    assert_same_replay(read_replay_file(tmp_path / PICKLED_REPLAY_FILE), buffer)


def write_pickled_replay(run_dir, model, episodes: int) -> None:
    """A replay folder as ``write_checkpoint`` wrote it before ``replay.npz``."""
    _write_folder(run_dir / CHECKPOINTS, f"replay_{episodes:07d}", LATEST_REPLAY,
                  lambda folder: model.save_replay_buffer(folder / PICKLED_REPLAY_FILE), {"episodes": episodes})


def test_a_run_saved_with_a_pickle_loads_it_and_its_next_save_is_compact(tmp_path, collected):
    model, fresh = collected
    write_pickled_replay(tmp_path, model, 1)
    old = latest_replay(tmp_path)
    assert old.name == PICKLED_REPLAY_FILE
    resumed = fresh()
    load_replay(resumed, old)
    assert_same_replay(resumed.replay_buffer, model.replay_buffer)
    write_checkpoint(tmp_path, resumed, {"episodes": 2, "timesteps": 25})
    assert latest_replay(tmp_path).name == REPLAY_FILE
    assert not old.parent.exists()  # the older replay folder is pruned once the new one is published


def test_a_pickle_inside_the_model_checkpoint_of_an_older_run_is_found(tmp_path, collected):
    model, fresh = collected
    write_checkpoint(tmp_path, model, {"episodes": 3, "timesteps": 25}, with_replay=False)
    checkpoint = tmp_path / CHECKPOINTS / "episode_0000003"
    assert latest_replay(tmp_path) is None
    model.save_replay_buffer(checkpoint / PICKLED_REPLAY_FILE)
    assert latest_replay(tmp_path) == checkpoint / PICKLED_REPLAY_FILE
    resumed = fresh()
    load_replay(resumed, latest_replay(tmp_path))
    assert_same_replay(resumed.replay_buffer, model.replay_buffer)


def test_a_replay_folder_pointer_without_its_file_falls_back_to_the_model_checkpoint(tmp_path, collected):
    model, _ = collected
    write_checkpoint(tmp_path, model, {"episodes": 4, "timesteps": 25})
    (tmp_path / CHECKPOINTS / "replay_0000004" / REPLAY_FILE).unlink()
    assert latest_replay(tmp_path) is None


def test_hrl4in_saves_and_loads_both_levels_in_one_compact_file(tmp_path, one_torch_thread):
    config = resolve_config("PointNav", "hrl4in", preset="tiny", episodes=1)
    env = make_training_env(config)
    try:
        model = build_model(config, env)
        model.learn(total_timesteps=12)
        assert model.high.replay_buffer.size() > 0
        save_replay(model, tmp_path / REPLAY_FILE)
        resumed = build_model(config, env)
        load_replay(resumed, tmp_path / REPLAY_FILE)
    finally:
        env.close()
    for name, buffer in replay_buffers(model).items():
        assert_same_replay(replay_buffers(resumed)[name], buffer)
    assert set(read_replay_file(tmp_path / REPLAY_FILE)) == {"high", "low"}
