"""SelfCollisionCopy: one broadphase on a self-colliding copy gives the same answer as testing
every link pair with getClosestPoints on the body itself."""

from __future__ import annotations

import itertools

import numpy as np
import pybullet as p
import pytest

from relmogen.robots.spec import load_spec
from relmogen.simulation.bodies import movable_joints
from relmogen.simulation.self_collision import SelfCollisionCopy


@pytest.fixture(params=["fetch", "movo"])
def urdf(request):
    return load_spec(request.param).urdf_path


@pytest.fixture
def body(urdf):
    """The body as the robot loads it (no self-collision), alone in its own client."""
    client = p.connect(p.DIRECT)
    yield client, p.loadURDF(str(urdf), useFixedBase=True, physicsClientId=client)
    p.disconnect(client)


def all_pairs(client: int, body: int) -> list[tuple[int, int]]:
    """Every pair of links that are not parent and child."""
    joints = range(p.getNumJoints(body, physicsClientId=client))
    parents = {j: p.getJointInfo(body, j, physicsClientId=client)[16] for j in joints}
    links = [-1, *parents]
    return [(a, b) for a, b in itertools.combinations(links, 2) if parents.get(b) != a and parents.get(a) != b]


def touching_pairs(client: int, body: int, pairs) -> set[tuple[int, int]]:
    return {(a, b) for a, b in pairs
            if p.getClosestPoints(body, body, 0.0, linkIndexA=a, linkIndexB=b, physicsClientId=client)}


def random_poses(client: int, body: int, count: int, seed: int = 0):
    """Uniform random positions of every movable joint within its limits."""
    joints = movable_joints(client, body)
    limits = np.array([p.getJointInfo(body, j, physicsClientId=client)[8:10] for j in joints])
    lower, upper = limits[:, 0], np.maximum(limits[:, 1], limits[:, 0])
    rng = np.random.default_rng(seed)
    return joints, [rng.uniform(lower, upper) for _ in range(count)]


def set_joints(client: int, body: int, joints, positions) -> None:
    p.resetJointStatesMultiDof(body, joints, targetValues=[[q] for q in positions], physicsClientId=client)


def test_copy_agrees_with_every_pair_tested_on_the_body(body, urdf):
    client, robot = body
    pairs = all_pairs(client, robot)
    # pairs touching with every joint at zero are left out (as ArmCollisionChecker drops the pairs
    # touching in the tucked pose): the copy must ignore them too
    pairs = [pair for pair in pairs if pair not in touching_pairs(client, robot, pairs)]
    copy = SelfCollisionCopy(urdf, pairs)
    joints, poses = random_poses(client, robot, 300)
    expected, answers = [], []
    for q in poses:
        set_joints(client, robot, joints, q)
        expected.append(bool(touching_pairs(client, robot, pairs)))
        answers.append(copy.touching(joints, q))
    assert answers == expected
    assert 0 < sum(expected) < len(expected)  # both kinds were seen
    copy.close()


def test_a_pair_left_out_is_never_reported(body, urdf):
    client, robot = body
    pairs = all_pairs(client, robot)
    joints, poses = random_poses(client, robot, 300, seed=1)
    for q in poses:
        set_joints(client, robot, joints, q)
        touching = touching_pairs(client, robot, pairs)
        if len(touching) == 1:
            break
    else:
        pytest.skip("no pose with exactly one touching pair")
    only = next(iter(touching))
    with_it = SelfCollisionCopy(urdf, pairs)
    without_it = SelfCollisionCopy(urdf, [pair for pair in pairs if pair != only])
    assert with_it.touching(joints, q)
    assert not without_it.touching(joints, q)


def test_close_disconnects_the_client(urdf):
    copy = SelfCollisionCopy(urdf, [])
    assert p.isConnected(copy.client)
    copy.close()
    assert not p.isConnected(copy.client)
    copy.close()  # twice is fine
