"""Fixtures of the arm tests: a world with a floor plane and a Fetch at the origin."""

from __future__ import annotations

import pybullet as p
import pybullet_data
import pytest

from relmogen.robots.robot import Robot
from relmogen.robots.spec import load_spec
from relmogen.simulation.world import World


@pytest.fixture
def world():
    w = World()
    p.loadURDF(pybullet_data.getDataPath() + "/plane.urdf", physicsClientId=w.client)
    yield w
    w.close()


@pytest.fixture
def robot(world):
    return Robot(world.client, load_spec("fetch"))
