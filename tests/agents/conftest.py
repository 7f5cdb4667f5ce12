"""Fixtures of the relmogen-d tests (``test_dqn*.py``); helpers are in ``dqn_helpers.py``."""

import pytest
import torch as th
from dqn_helpers import SMALL_NET, make_env
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.dqn import RelmogenDQN


@pytest.fixture(scope="module")
def one_torch_thread():
    """Two OpenMP threads on a loaded 2-core machine run ~50x slower than one."""
    threads = th.get_num_threads()
    th.set_num_threads(1)
    yield
    th.set_num_threads(threads)


@pytest.fixture(scope="module")
def model():
    """A small relmogen-d model on PointNav (subgoal-d, 64 px), one per test module."""
    dqn = RelmogenDQN(env=DummyVecEnv([make_env]), buffer_size=64, batch_size=4, learning_starts=0,
                      policy_kwargs=SMALL_NET, seed=0)
    yield dqn
    dqn.env.close()
