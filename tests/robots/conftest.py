"""Fixtures: a fresh DIRECT PyBullet client per test, with the physics settings the env uses."""

from __future__ import annotations

import pybullet as p
import pybullet_data
import pytest

from relmogen.robots.robot import Robot
from relmogen.robots.spec import load_spec

TIME_STEP = 0.025
NUM_SUB_STEPS = 2  # 0 sub-steps lets the wheel/floor contact yaw the base (see the robots report)


@pytest.fixture
def client():
    cid = p.connect(p.DIRECT)
    p.setGravity(0, 0, -9.81, physicsClientId=cid)
    p.setPhysicsEngineParameter(fixedTimeStep=TIME_STEP, numSubSteps=NUM_SUB_STEPS, physicsClientId=cid)
    yield cid
    p.disconnect(cid)


@pytest.fixture
def floor(client):
    return p.loadURDF(pybullet_data.getDataPath() + "/plane.urdf", physicsClientId=client)


@pytest.fixture
def fetch_spec():
    return load_spec("fetch")


@pytest.fixture
def robot(client, floor, fetch_spec):
    return Robot(client, fetch_spec)
