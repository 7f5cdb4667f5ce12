"""The coal collision backend answers the arm's queries as the PyBullet check does (away from
contact), keeps the gripper's penetration allowances, rebuilds its world when a body moved, and
refuses a colliding body whose boxes it cannot read (conftest.py's world: a URDF floor plane)."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.motion_generation.arm import ArmCollisionChecker, ArmConfig, ArmMotion
from relmogen.motion_generation.coal_collision import UnknownCollisionGeometry
from relmogen.robots.robot import Robot
from relmogen.simulation.shapes import box_collision_shape, ignore_contacts, record_body


def add_box(client: int, half_extents, position, mass: float = 0.0) -> int:
    shape = box_collision_shape(client, [half_extents])
    return record_body(client, p.createMultiBody(mass, shape, -1, list(position), physicsClientId=client), {-1: shape})


def checkers(client: int, robot: Robot, allowance: float = 0.03, target_allowance: float = 0.08):
    return [ArmCollisionChecker(client, robot, allowance, target_allowance, backend=backend)
            for backend in ("pybullet", "coal")]


def answers(checker: ArmCollisionChecker, robot: Robot, configurations: np.ndarray) -> np.ndarray:
    saved = robot.joint_state_vector()[0]
    with checker.other_joints_held():
        result = np.array([checker(q) for q in configurations])
    robot.set_joint_positions(robot.arm_joint_indices, saved)
    return result


def test_coal_agrees_with_pybullet_on_random_arm_configurations_in_a_task_scene():
    env = RelmogenEnv(task="TabletopReachM", control="subgoal-r", image_size=32)
    env.reset(seed=1)
    pybullet_checker, coal_checker = checkers(env.world.client, env.robot)
    rng = np.random.default_rng(0)
    current = env.robot.joint_state_vector()[0]
    configurations = np.concatenate([  # anywhere in the limits, and near the tucked pose (table, self)
        rng.uniform(pybullet_checker.lower, pybullet_checker.upper, (200, 8)),
        np.clip(current + rng.normal(0.0, 0.4, (200, 8)), pybullet_checker.lower, pybullet_checker.upper)])
    expected, got = answers(pybullet_checker, env.robot, configurations), answers(coal_checker, env.robot, configurations)
    env.close()
    assert 0.2 < expected.mean() < 0.8  # both answers occur
    # they differ only near contact: PyBullet's URDF cylinders are convex hulls, Coal's exact
    assert np.mean(expected == got) >= 0.98
    assert np.sum(got & ~expected) <= 2


def test_coal_keeps_the_grippers_allowances_in_the_pushed_body_and_in_any_other(world, robot):
    arm = ArmMotion(world.client, robot)
    reach = arm.ik(np.array([0.8, 0.0, 0.9]), np.random.default_rng(0))
    robot.set_joint_positions(robot.arm_joint_indices, reach)
    gripper = robot.end_effector_position()
    box = add_box(world.client, [0.1, 0.3, 0.3], gripper + [0.5, 0, 0])
    for x in np.arange(0.5, 0.0, -0.002):  # slide the box in until the gripper is 5 cm deep
        p.resetBasePositionAndOrientation(box, (gripper + [x, 0, 0]).tolist(), [0, 0, 0, 1],
                                          physicsClientId=world.client)
        if arm._gripper_penetration(box) >= 0.05:
            break
    for checker in checkers(world.client, robot):
        verdicts = []
        for target in (None, box):
            checker.target_body = target
            verdicts.append(answers(checker, robot, reach[None])[0])
        assert verdicts == [True, False], checker.backend  # 5 cm: beyond 3 cm, within the pushed body's 8


def test_link_pairs_without_contacts_are_left_out_as_pybullet_leaves_them_out(world, robot):
    arm = ArmMotion(world.client, robot)
    reach = arm.ik(np.array([0.8, 0.0, 0.9]), np.random.default_rng(0))
    robot.set_joint_positions(robot.arm_joint_indices, reach)
    finger = robot.link_index("l_gripper_finger_link")
    finger_position = robot.link_pose(finger)[0]
    robot.set_joint_positions(robot.arm_joint_indices, arm.default_config)
    pin_box = add_box(world.client, [0.005, 0.005, 0.005], finger_position)  # inside the finger alone
    for checker in checkers(world.client, robot, allowance=0.0):
        assert answers(checker, robot, reach[None])[0], checker.backend
    checkers_before = checkers(world.client, robot, allowance=0.0)
    for checker in checkers_before:
        answers(checker, robot, reach[None])  # Coal's world is built, with the pair
    ignore_contacts(world.client, robot.robot_id, finger, pin_box, -1)
    for checker in checkers_before:  # nothing moved, but the pair is gone: Coal rebuilds
        assert not answers(checker, robot, reach[None])[0], checker.backend


def test_a_moved_body_is_seen_by_the_next_hold(world, robot):
    _, coal_checker = checkers(world.client, robot)
    arm = ArmMotion(world.client, robot)
    reach = arm.ik(np.array([0.8, 0.0, 0.9]), np.random.default_rng(0))
    robot.set_joint_positions(robot.arm_joint_indices, reach)
    obstacle = add_box(world.client, [0.1, 0.1, 0.1], robot.end_effector_position() - [0.15, 0, 0])
    robot.set_joint_positions(robot.arm_joint_indices, arm.default_config)
    assert answers(coal_checker, robot, reach[None])[0]
    p.resetBasePositionAndOrientation(obstacle, [3.0, 3.0, 0.1], [0, 0, 0, 1], physicsClientId=world.client)
    assert not answers(coal_checker, robot, reach[None])[0]


def test_bodies_coal_cannot_read_are_an_error_and_those_pybullet_describes_are_used(world, robot):
    _, coal_checker = checkers(world.client, robot)
    arm = ArmMotion(world.client, robot)
    reach = arm.ik(np.array([0.8, 0.0, 0.9]), np.random.default_rng(0))
    robot.set_joint_positions(robot.arm_joint_indices, reach)
    in_the_way = (robot.end_effector_position() - [0.15, 0, 0]).tolist()
    robot.set_joint_positions(robot.arm_joint_indices, arm.default_config)
    visual = p.createVisualShape(p.GEOM_SPHERE, radius=0.05, physicsClientId=world.client)
    p.createMultiBody(0.0, -1, visual, in_the_way, physicsClientId=world.client)  # visual only: ignored
    assert not answers(coal_checker, robot, reach[None])[0]
    sphere = p.createCollisionShape(p.GEOM_SPHERE, radius=0.1, physicsClientId=world.client)
    body = p.createMultiBody(0.0, sphere, -1, in_the_way, physicsClientId=world.client)  # PyBullet describes it
    assert answers(coal_checker, robot, reach[None])[0]
    p.removeBody(body, physicsClientId=world.client)
    compound = p.createCollisionShapeArray([p.GEOM_BOX] * 2, halfExtents=[[0.1] * 3] * 2,
                                           collisionFramePositions=[[0, 0, 0], [0, 0, 0.2]], physicsClientId=world.client)
    p.createMultiBody(0.0, compound, -1, in_the_way, useMaximalCoordinates=True,  # PyBullet cannot describe it
                      physicsClientId=world.client)
    with pytest.raises(UnknownCollisionGeometry, match="record_body"):
        answers(coal_checker, robot, reach[None])


def test_an_arm_subgoal_planned_with_coal_pushes_a_box(world, robot):
    box = add_box(world.client, [0.15, 0.15, 0.15], [0.9, 0.0, 0.65], mass=2.0)
    add_box(world.client, [0.2, 0.3, 0.25], [0.9, 0.0, 0.25])  # pedestal
    world.step(10)
    start = np.array(p.getBasePositionAndOrientation(box, physicsClientId=world.client)[0])
    arm = ArmMotion(world.client, robot, ArmConfig(collision_backend="coal"))
    result = arm.reach_and_push(np.array([0.74, 0.0, 0.65]), np.array([0.2, 0.0, 0.0]), np.random.default_rng(0))
    assert result.success, result.reason
    moved = np.array(p.getBasePositionAndOrientation(box, physicsClientId=world.client)[0]) - start
    assert moved[0] == pytest.approx(0.2, rel=0.4)
    with pytest.raises(ValueError, match="pybullet, coal"):
        ArmCollisionChecker(world.client, robot, 0.03, backend="fcl")
