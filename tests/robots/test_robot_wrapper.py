"""Robot wrapper: kinematics against the hand-summed joint chain, and base/torso physics."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pytest


# Joint-origin sums from fetch_description (facts sheet section 3), base at the origin.
BASE_TO_TORSO = np.array([-0.086875, 0.0, 0.37743])
TORSO_TO_SHOULDER_LIFT = np.array([0.119525 + 0.117, 0.0, 0.34858 + 0.06])
SHOULDER_LIFT_TO_GRIPPER = 0.219 + 0.133 + 0.197 + 0.1245 + 0.1385 + 0.16645  # all along the arm's x
WHEEL_RADIUS, WHEEL_Z = 0.0613, 0.055325
BASE_HEIGHT = WHEEL_RADIUS - WHEEL_Z  # base_link origin above the floor when the wheels touch it


def _expected_gripper(torso: float, arm_up: bool) -> np.ndarray:
    shoulder = BASE_TO_TORSO + TORSO_TO_SHOULDER_LIFT + [0.0, 0.0, BASE_HEIGHT + torso]
    direction = np.array([0.0, 0.0, 1.0]) if arm_up else np.array([1.0, 0.0, 0.0])
    return shoulder + SHOULDER_LIFT_TO_GRIPPER * direction


def test_gripper_position_at_zero_pose(robot):
    robot.set_joint_positions(robot.arm_joint_indices, np.zeros(8))
    expected = [-0.086875 + 0.119525 + 0.117 + 0.219 + 0.133 + 0.197 + 0.1245 + 0.1385 + 0.16645, 0.0,
                BASE_HEIGHT + 0.37743 + 0.34858 + 0.06]
    np.testing.assert_allclose(robot.end_effector_position(), expected, atol=1e-3)
    np.testing.assert_allclose(robot.end_effector_position(), _expected_gripper(0.0, False), atol=1e-3)


def test_gripper_position_arm_up_torso_raised(robot):
    q = np.zeros(8)
    q[0], q[2] = 0.38615, -np.pi / 2  # torso at its upper limit, shoulder_lift = -pi/2 points the arm up
    robot.set_joint_positions(robot.arm_joint_indices, q)
    np.testing.assert_allclose(robot.end_effector_position(), _expected_gripper(0.38615, True), atol=1e-3)


def test_kinematics_follow_the_base_pose(robot):
    robot.set_base_pose(1.0, -2.0, np.pi / 2)
    robot.set_joint_positions(robot.arm_joint_indices, np.zeros(8))
    local = _expected_gripper(0.0, False)
    np.testing.assert_allclose(robot.end_effector_position(), [1.0, -2.0 + local[0], local[2]], atol=1e-3)
    np.testing.assert_allclose(robot.base_pose(), [1.0, -2.0, np.pi / 2], atol=1e-9)


def test_reset_sets_tucked_pose_and_sensor_frames(robot, fetch_spec):
    robot.reset((0.5, 0.5, 0.3), head_tilt=fetch_spec.head_tilt_tabletop)
    positions, velocities = robot.joint_state_vector()
    np.testing.assert_allclose(positions, [fetch_spec.default_torso, *fetch_spec.default_arm_pose], atol=1e-9)
    assert not velocities.any()
    np.testing.assert_allclose(robot.base_pose(), [0.5, 0.5, 0.3], atol=1e-9)
    cam_pos, cam_rot = robot.camera_pose()
    assert 1.0 < cam_pos[2] < 1.6 and cam_rot[2, 0] < -0.5  # camera looks ~45 deg down
    lidar_pos, lidar_yaw = robot.lidar_pose()
    assert abs(lidar_pos[2] - (BASE_HEIGHT + 0.2878)) < 1e-6 and abs(lidar_yaw - 0.3) < 1e-6
    assert robot.link_index(fetch_spec.end_effector_link) in robot.gripper_link_indices


def test_standing_still_does_not_drift_or_tip(client, robot):
    start = robot.base_pose()
    step(client, 200)
    (_, _, z), orn = robot.link_pose(-1)
    roll, pitch, _ = p.getEulerFromQuaternion(orn)
    assert np.isfinite(robot.base_pose()).all()
    assert np.linalg.norm(robot.base_pose()[:2] - start[:2]) < 0.02
    assert abs(z - BASE_HEIGHT) < 0.005 and abs(roll) < 0.01 and abs(pitch) < 0.01
    positions, _ = robot.joint_state_vector()
    np.testing.assert_allclose(positions[1:], robot.spec.default_arm_pose, atol=0.02)


def step(client: int, n: int) -> None:
    for _ in range(n):
        p.stepSimulation(physicsClientId=client)


def _drive(client, robot, action, steps=40):
    for _ in range(steps):
        robot.apply_normalized_velocity(action)
        step(client, 1)


@pytest.mark.parametrize("yaw", [0.0, 1.2])
def test_both_wheels_forward_drive_straight(client, robot, yaw):
    robot.reset((0.0, 0.0, yaw))
    action = np.zeros(10)
    action[:2] = 1.0
    _drive(client, robot, action)
    x, y, new_yaw = robot.base_pose()
    forward = x * np.cos(yaw) + y * np.sin(yaw)
    lateral = -x * np.sin(yaw) + y * np.cos(yaw)
    top_speed = robot.spec.velocity_limits[0] * robot.spec.wheel_radius
    assert 0.7 * top_speed < forward < 1.05 * top_speed  # 1 s of driving, including the spin-up
    assert abs(lateral) < 0.03 and abs(new_yaw - yaw) < 0.05
    assert robot.base_velocity()[0] > 0.8 * top_speed


def test_opposite_wheels_turn_in_place(client, robot):
    action = np.zeros(10)
    action[0], action[1] = -1.0, 1.0
    _drive(client, robot, action)
    x, y, yaw = robot.base_pose()
    top_rate = 2 * robot.spec.velocity_limits[0] * robot.spec.wheel_radius / robot.spec.wheel_separation
    assert 0.7 * top_rate < yaw < 1.05 * top_rate
    assert np.hypot(x, y) < 0.05


def test_torso_rises_with_positive_velocity(client, robot):
    action = np.zeros(10)
    action[2] = 1.0
    _drive(client, robot, action)
    torso = robot.get_joint_positions(robot.arm_joint_indices[:1])[0]
    assert torso > robot.spec.default_torso + 0.05  # 0.1 m/s for 1 s


def test_command_joint_positions_reaches_target(client, robot):
    target = np.array(robot.spec.default_arm_pose)
    target[0] -= 0.5
    robot.command_joint_positions(robot.arm_joint_indices[1:], target)
    step(client, 80)
    np.testing.assert_allclose(robot.joint_state_vector()[0][1:], target, atol=0.05)
