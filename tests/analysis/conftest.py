"""Tiny trained runs shared by the analysis tests (the ``tiny`` preset: 10 subgoals per episode)."""

import pytest
import torch as th

from relmogen.experiments.config import resolve_config
from relmogen.experiments.train import train


def tiny_run(tmp_path_factory, task: str, algo: str, episodes: int):
    """A ``tiny``-preset run of ``episodes`` (seed 0) with its checkpoint; torch's thread count restored."""
    threads = th.get_num_threads()
    run = train(resolve_config(task, algo, seed=0, preset="tiny", episodes=episodes),
                tmp_path_factory.mktemp(f"tiny_{task}_{algo}"), quiet=True)
    th.set_num_threads(threads)
    return run


@pytest.fixture(scope="session")
def tiny_dqn_run(tmp_path_factory):
    """A ButtonDoorNav relmogen-d run of 2 episodes: a checkpoint and its replay (19 transitions)."""
    return tiny_run(tmp_path_factory, "ButtonDoorNav", "relmogen-d", episodes=2)


@pytest.fixture(scope="session")
def tiny_sac_run(tmp_path_factory):
    """A PushDoorNav relmogen-r run of 1 episode with its checkpoint."""
    return tiny_run(tmp_path_factory, "PushDoorNav", "relmogen-r", episodes=1)


@pytest.fixture(scope="session")
def tiny_tabletop_run(tmp_path_factory):
    """A TabletopReachM relmogen-r run of 1 episode with its checkpoint."""
    return tiny_run(tmp_path_factory, "TabletopReachM", "relmogen-r", episodes=1)
