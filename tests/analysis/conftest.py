"""Tiny trained runs shared by the analysis tests (the ``tiny`` preset: 10 subgoals per episode)."""

import pytest
import torch as th

from relmogen.experiments.config import resolve_config
from relmogen.experiments.train import train


@pytest.fixture(scope="session")
def tiny_dqn_run(tmp_path_factory):
    """A ButtonDoorNav relmogen-d run of 2 episodes: a checkpoint and its replay (19 transitions)."""
    threads = th.get_num_threads()
    run = train(resolve_config("ButtonDoorNav", "relmogen-d", seed=0, preset="tiny", episodes=2),
                tmp_path_factory.mktemp("tiny_dqn"), quiet=True)
    th.set_num_threads(threads)
    return run


@pytest.fixture(scope="session")
def tiny_sac_run(tmp_path_factory):
    """A PushDoorNav relmogen-r run of 1 episode with its checkpoint."""
    threads = th.get_num_threads()
    run = train(resolve_config("PushDoorNav", "relmogen-r", seed=0, preset="tiny", episodes=1),
                tmp_path_factory.mktemp("tiny_sac"), quiet=True)
    th.set_num_threads(threads)
    return run
