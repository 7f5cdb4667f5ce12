"""Box collision shapes are recorded per body and link, and forgotten with their client."""

from __future__ import annotations

import pybullet as p
import pytest

from relmogen.simulation.shapes import LocalBox, base_inertial_position, body_boxes, box_collision_shape, record_body
from relmogen.simulation.world import World


def test_a_recorded_body_gives_back_each_links_boxes_and_its_inertial_offset():
    world = World()
    client = world.client
    single = box_collision_shape(client, [(0.1, 0.2, 0.3)], [(0.0, 0.0, 0.3)])
    compound = box_collision_shape(client, [(0.05, 0.05, 0.05), (0.2, 0.01, 0.01)], [(0, 0, 0), (0.2, 0, 0)])
    body = record_body(client, p.createMultiBody(
        baseMass=1.0, baseCollisionShapeIndex=single, baseInertialFramePosition=[0, 0, 0.3],
        linkMasses=[0.5], linkCollisionShapeIndices=[compound], linkVisualShapeIndices=[-1],
        linkPositions=[[0, 0, 0.6]], linkOrientations=[[0, 0, 0, 1]], linkInertialFramePositions=[[0, 0, 0]],
        linkInertialFrameOrientations=[[0, 0, 0, 1]], linkParentIndices=[0], linkJointTypes=[p.JOINT_REVOLUTE],
        linkJointAxis=[[0, 0, 1]], physicsClientId=client), {-1: single, 0: compound},
        base_inertial_position=(0, 0, 0.3))
    boxes = body_boxes(client, body)
    assert boxes[-1] == (LocalBox((0.1, 0.2, 0.3), (0.0, 0.0, 0.3)),)
    assert [box.half_extents for box in boxes[0]] == [(0.05, 0.05, 0.05), (0.2, 0.01, 0.01)]
    assert base_inertial_position(client, body) == (0.0, 0.0, 0.3)
    assert body_boxes(client, body + 1) is None
    world.close()
    assert body_boxes(client, body) is None  # a later connection may reuse the client id


def test_positions_must_match_the_boxes():
    world = World()
    with pytest.raises(ValueError, match="one position per box"):
        box_collision_shape(world.client, [(0.1, 0.1, 0.1), (0.2, 0.2, 0.2)], [(0, 0, 0)])
    world.close()
