"""Tiny trained runs shared by the figure tests (``viz subgoals``, ``viz exploration``)."""

import pytest
import torch as th

from relmogen.experiments.config import resolve_config
from relmogen.experiments.train import train

TINY_EPISODES = {"relmogen-r": 2, "relmogen-d": 1, "sac": 1}  # PushDoorNav, 10 steps per episode


@pytest.fixture(scope="session")
def tiny_runs(tmp_path_factory):
    """algo -> run directory of a PushDoorNav run on the ``tiny`` preset (a checkpoint every episode)."""
    threads = th.get_num_threads()
    out = tmp_path_factory.mktemp("tiny_runs")
    runs = {algo: train(resolve_config("PushDoorNav", algo, seed=0, preset="tiny", episodes=episodes), out, quiet=True)
            for algo, episodes in TINY_EPISODES.items()}
    th.set_num_threads(threads)
    return runs
