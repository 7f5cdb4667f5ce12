"""Arm motion generator: IK, collision function, joint-space plans and physical pushes."""

from __future__ import annotations

import numpy as np
import pybullet as p
import pybullet_data
import pytest

from relmogen.motion_generation.arm import ArmConfig, ArmMotion
from relmogen.motion_generation.planners import BACKENDS
from relmogen.robots.robot import Robot
from relmogen.robots.spec import load_spec
from relmogen.simulation.sensors import Camera, CameraFrame
from relmogen.simulation.world import World

RESOLUTION = 0.05
PUSH = np.array([0.2, 0.0, 0.0])


def add_box(client: int, half_extents, position, mass: float = 0.0) -> int:
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half_extents), physicsClientId=client)
    return p.createMultiBody(mass, shape, -1, list(position), physicsClientId=client)


def add_door(client: int, hinge=(0.8, -0.35, 0.05), width=0.6, height=1.2, damping=2.0) -> int:
    """A static frame with one thin panel on a vertical revolute hinge at its -y edge."""
    panel = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.015, width / 2, height / 2],
                                   collisionFramePosition=[0, width / 2, height / 2], physicsClientId=client)
    door = p.createMultiBody(
        baseMass=0.0, basePosition=list(hinge), linkMasses=[8.0], linkCollisionShapeIndices=[panel],
        linkVisualShapeIndices=[-1], linkPositions=[[0, 0, 0]], linkOrientations=[[0, 0, 0, 1]],
        linkInertialFramePositions=[[0, width / 2, height / 2]], linkInertialFrameOrientations=[[0, 0, 0, 1]],
        linkParentIndices=[0], linkJointTypes=[p.JOINT_REVOLUTE], linkJointAxis=[[0, 0, 1]],
        physicsClientId=client)
    p.changeDynamics(door, 0, jointDamping=damping, physicsClientId=client)
    p.setJointMotorControl2(door, 0, p.VELOCITY_CONTROL, force=0.0, physicsClientId=client)
    return door


def body_position(client: int, body: int) -> np.ndarray:
    return np.array(p.getBasePositionAndOrientation(body, physicsClientId=client)[0])


def planning_joints(robot: Robot) -> np.ndarray:
    return robot.joint_state_vector()[0]


# ---------------------------------------------------------------------------- IK


def test_ik_reaches_point_in_front_and_restores_state(world, robot):
    arm = ArmMotion(world.client, robot)
    before = planning_joints(robot)
    target = np.array([0.7, 0.1, 0.8])
    q = arm.ik(target, np.random.default_rng(0))
    assert q is not None and q.shape == (8,)
    np.testing.assert_allclose(planning_joints(robot), before)
    base = robot.base_pose()
    robot.set_joint_positions(robot.arm_joint_indices, q)
    assert np.linalg.norm(robot.end_effector_position() - target) <= 0.05
    assert np.all(q >= robot.joint_lower[robot.arm_joint_indices])
    assert np.all(q <= robot.joint_upper[robot.arm_joint_indices])
    np.testing.assert_allclose(robot.base_pose(), base)


def test_ik_works_with_moved_and_rotated_base(world):
    robot = Robot(world.client, load_spec("fetch"), base_pose=(1.0, 2.0, 0.7))
    arm = ArmMotion(world.client, robot)
    c, s = np.cos(0.7), np.sin(0.7)
    target = np.array([1.0 + 0.65 * c, 2.0 + 0.65 * s, 0.8])
    q = arm.ik(target, np.random.default_rng(0))
    assert q is not None
    robot.set_joint_positions(robot.arm_joint_indices, q)
    assert np.linalg.norm(robot.end_effector_position() - target) <= 0.05


def test_ik_unreachable_point_returns_none(world, robot):
    arm = ArmMotion(world.client, robot)
    result = arm.solve_ik(np.array([3.0, 0.0, 0.8]), np.random.default_rng(0))
    assert result.config is None
    assert result.reason == "no IK solution within 0.05 m"
    assert result.attempts == ArmConfig().ik_restarts


def test_ik_abandons_an_attempt_still_far_away_after_its_probe_iterations(world, robot, monkeypatch):
    from relmogen.motion_generation import ik as ik_module

    arm, calls = ArmMotion(world.client, robot), []
    raw_ik = arm.ik_solver._raw_ik
    monkeypatch.setattr(arm.ik_solver, "_raw_ik", lambda *args: calls.append(args[-1]) or raw_ik(*args))
    result = arm.solve_ik(np.array([3.0, 0.0, 0.8]), np.random.default_rng(0))
    assert result.config is None and result.error_m > ik_module.ABANDON_DISTANCE_M
    assert calls == [ik_module.PROBE_ITERATIONS] * ArmConfig().ik_restarts  # never the remaining 80
    calls.clear()
    assert arm.ik(np.array([0.7, 0.1, 0.8]), np.random.default_rng(0)) is not None
    assert calls[:2] == [ik_module.PROBE_ITERATIONS, ArmConfig().ik_iterations - ik_module.PROBE_ITERATIONS]


def test_ik_point_deep_inside_a_box_is_in_collision(world, robot):
    add_box(world.client, [0.25, 0.25, 0.25], [0.75, 0.0, 0.8])
    arm = ArmMotion(world.client, robot, ArmConfig(ik_restarts=10))
    result = arm.reach_and_push([0.75, 0.0, 0.8], PUSH, np.random.default_rng(0))
    assert not result.success and result.reason == "IK solution in collision"
    np.testing.assert_allclose(planning_joints(robot), arm.default_config, atol=1e-6)


# ---------------------------------------------------------------------------- collision function


def test_collision_fn_flags_arm_inside_box_and_not_tucked_pose(world, robot):
    arm = ArmMotion(world.client, robot)
    q = arm.ik(np.array([0.7, 0.0, 0.8]), np.random.default_rng(0))
    collision_fn = arm.collision_fn()
    assert not collision_fn(arm.default_config)
    assert not collision_fn(q)
    robot.set_joint_positions(robot.arm_joint_indices, q)
    elbow = robot.link_pose(robot.link_index("elbow_flex_link"))[0]
    robot.set_joint_positions(robot.arm_joint_indices, arm.default_config)
    add_box(world.client, [0.05, 0.05, 0.05], elbow)
    assert collision_fn(q)
    assert not collision_fn(arm.default_config)
    unchecked = ArmMotion(world.client, robot, ArmConfig(collision_checking=False)).collision_fn()
    assert not unchecked(q)
    assert unchecked(q + 10.0)  # joint limits still hold


def test_collision_fn_flags_arm_folded_into_base(world, robot):
    arm = ArmMotion(world.client, robot)
    arm_down_through_base = np.array([0.0, 0.0, 1.5, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert arm.collision_fn()(arm_down_through_base)
    assert arm.checker.self_pairs and not arm.checker.ignored_pairs


def test_collision_fn_agrees_with_testing_every_self_pair_on_the_robot(world, robot):
    """The self-collision copy (head and fingers mirrored) answers as getClosestPoints on each
    self pair of the robot itself would, over random arm, head and finger positions."""
    add_box(world.client, [0.3, 0.5, 0.36], [0.85, 0.0, 0.36])  # a table in front
    arm = ArmMotion(world.client, robot)
    checker, body, rng = arm.checker, robot.robot_id, np.random.default_rng(0)
    others = np.concatenate([robot.head_joint_indices, robot.gripper_joint_indices])
    outcomes = []
    for _ in range(300):
        robot.set_joint_positions(others, rng.uniform(robot.joint_lower[others], robot.joint_upper[others]))
        q = rng.uniform(checker.lower, checker.upper)
        robot.set_joint_positions(robot.arm_joint_indices, q)
        self_hit = any(p.getClosestPoints(body, body, 0.0, linkIndexA=a, linkIndexB=b, physicsClientId=world.client)
                       for a, b in checker.self_pairs)
        world_hit = checker._hits_world()
        assert checker(q) == (world_hit or self_hit)
        outcomes.append((world_hit, self_hit))
    assert {(False, False), (False, True), (True, False)} <= set(outcomes)


def test_while_the_other_joints_are_held_the_checker_answers_as_when_it_mirrors_them_per_query(world, robot):
    add_box(world.client, [0.3, 0.5, 0.36], [0.85, 0.0, 0.36])
    arm = ArmMotion(world.client, robot)
    checker, rng = arm.checker, np.random.default_rng(1)
    others = np.concatenate([robot.head_joint_indices, robot.gripper_joint_indices])
    for _ in range(5):  # head and fingers somewhere else for each block
        robot.set_joint_positions(others, rng.uniform(robot.joint_lower[others], robot.joint_upper[others]))
        configs = [rng.uniform(checker.lower, checker.upper) for _ in range(40)]
        mirrored = [checker(q) for q in configs]
        with checker.other_joints_held(), checker.other_joints_held():  # nested: an IK solve inside a plan
            held = [checker(q) for q in configs]
        assert held == mirrored and any(mirrored) and not all(mirrored)


# ---------------------------------------------------------------------------- planning


@pytest.mark.parametrize("backend", sorted(BACKENDS))
def test_planned_path_is_collision_free_at_resolution(world, robot, backend):
    add_box(world.client, [0.25, 0.4, 0.25], [0.85, 0.0, 0.25])  # table in front
    arm = ArmMotion(world.client, robot)
    arm.set_planner(backend, **({"time_limit_s": 5.0} if backend.startswith("ompl") else {}))
    rng = np.random.default_rng(0)
    goal = arm.ik(np.array([0.6, -0.3, 0.6]), rng)
    assert goal is not None
    result = arm.plan(goal, rng)
    assert result.success, result.reason
    np.testing.assert_allclose(planning_joints(robot), arm.default_config, atol=1e-6)
    path = np.array(result.path)
    np.testing.assert_allclose(path[0], arm.default_config, atol=1e-6)
    np.testing.assert_allclose(path[-1], goal)
    assert np.all(np.abs(np.diff(path, axis=0)) <= RESOLUTION + 1e-9)
    collision_fn = arm.collision_fn()
    assert not any(collision_fn(q) for q in path)


# ---------------------------------------------------------------------------- pushing


def push(world, robot, target, vector=PUSH, config: ArmConfig | None = None):
    arm = ArmMotion(world.client, robot, config or ArmConfig(planner="lazy_prm"))
    base = robot.base_pose()
    chunks: list[int] = []
    result = arm.reach_and_push(target, vector, np.random.default_rng(0), on_physics_steps=chunks.append)
    assert result.success, result.reason
    assert sum(chunks) == result.physics_steps > 0
    assert result.simulated_time_s == pytest.approx(result.physics_steps * world.time_step)
    assert np.linalg.norm(robot.base_pose()[:2] - base[:2]) < 0.01
    assert abs(robot.base_pose()[2] - base[2]) < 0.01
    np.testing.assert_allclose(planning_joints(robot), arm.default_config, atol=1e-6)
    return result


def test_push_moves_light_box_about_the_commanded_distance(world, robot):
    box = add_box(world.client, [0.15, 0.15, 0.15], [0.9, 0.0, 0.65], mass=2.0)
    add_box(world.client, [0.2, 0.3, 0.25], [0.9, 0.0, 0.25])  # pedestal
    world.step(10)
    start = body_position(world.client, box)
    result = push(world, robot, [0.74, 0.0, 0.65])
    moved = body_position(world.client, box) - start
    assert moved[0] == pytest.approx(0.2, rel=0.4)
    assert result.pushed_distance_m == pytest.approx(0.2, rel=0.4)


def test_push_cannot_move_a_heavy_box(world, robot):
    box = add_box(world.client, [0.15, 0.15, 0.15], [0.9, 0.0, 0.15], mass=1e4)
    world.step(10)
    start = body_position(world.client, box)
    result = push(world, robot, [0.745, 0.0, 0.2])
    assert np.linalg.norm(body_position(world.client, box) - start) < 0.01
    assert result.pushed_distance_m < 0.05


def test_push_opens_hinged_door(world, robot):
    door = add_door(world.client)
    push(world, robot, [0.77, 0.0, 0.8])
    angle = p.getJointState(door, 0, physicsClientId=world.client)[0]
    assert abs(angle) > 0.1


def test_push_vector_is_clipped_to_max_length(world, robot):
    result = push(world, robot, [0.6, 0.0, 0.8], vector=np.array([0.0, 0.5, 0.0]))
    assert result.pushed_distance_m == pytest.approx(ArmConfig().push_max_length, abs=0.03)


def test_pixel_without_depth_fails_cleanly(world, robot):
    arm = ArmMotion(world.client, robot)
    camera = Camera(world.client, width=8, height=8)
    frame = CameraFrame(np.zeros((8, 8, 3), np.uint8), np.zeros((8, 8), np.float32), np.zeros(3), np.eye(3))
    result = arm.reach_and_push_pixel(camera, frame, 3, 3, PUSH, np.random.default_rng(0))
    assert not result.success and result.reason == "pixel has no depth"


def test_default_push_keeps_the_original_duration_and_opens_a_door_as_far():
    """Fewer push waypoints, each held longer: the same 2.5 s of physics as the original 50 x 2
    and about the same effect on a hinged door."""
    defaults = ArmConfig()
    angles = []
    for points, steps in ((defaults.push_points, defaults.push_steps_per_point), (50, 2)):
        w = World()
        p.loadURDF(pybullet_data.getDataPath() + "/plane.urdf", physicsClientId=w.client)
        door = add_door(w.client)
        config = ArmConfig(planner="lazy_prm", push_points=points, push_steps_per_point=steps)
        result = push(w, Robot(w.client, load_spec("fetch")), [0.77, 0.0, 0.8], config=config)
        assert result.simulated_time_s - defaults.push_settle_steps * w.time_step == pytest.approx(2.5)
        angles.append(abs(p.getJointState(door, 0, physicsClientId=w.client)[0]))
        w.close()
    assert angles[0] > 0.1 and angles[0] == pytest.approx(angles[1], rel=0.2), angles


# ---------------------------------------------------------------------------- the pushed body


def box_around_gripper(world, robot, depth: float) -> tuple[ArmMotion, int]:
    """Reach straight ahead, then slide a wide static box in along -x until the gripper links are
    ``depth`` inside it (PyBullet's penetration depth), touching no other link."""
    arm = ArmMotion(world.client, robot)
    robot.set_joint_positions(robot.arm_joint_indices, arm.ik(np.array([0.8, 0.0, 0.9]), np.random.default_rng(0)))
    centre = robot.end_effector_position()
    box = add_box(world.client, [0.1, 0.3, 0.3], centre + [0.5, 0, 0])
    for x in np.arange(0.5, 0.0, -0.002):
        p.resetBasePositionAndOrientation(box, (centre + [x, 0, 0]).tolist(), [0, 0, 0, 1],
                                          physicsClientId=world.client)
        if arm._gripper_penetration(box) >= depth:
            break
    contacts = p.getClosestPoints(robot.robot_id, box, 0.0, physicsClientId=world.client)
    assert {c[3] for c in contacts} <= set(robot.gripper_link_indices)
    return arm, box


def test_the_gripper_may_go_deeper_into_the_pushed_body_than_into_any_other(world, robot):
    arm, box = box_around_gripper(world, robot, depth=0.05)
    config = arm.config
    assert config.gripper_penetration_allowance < 0.05 < config.target_penetration_allowance
    arm.checker.target_body = None
    assert arm.checker.current_pose_in_collision()
    arm.checker.target_body = box
    assert not arm.checker.current_pose_in_collision()
    other = add_box(world.client, [0.05, 0.05, 0.05], robot.link_pose(robot.gripper_link_indices[0])[0])
    assert arm.checker.current_pose_in_collision(), "only the pushed body is exempt"
    p.removeBody(other, physicsClientId=world.client)
    arm.checker.target_body = box
    p.resetBasePositionAndOrientation(box, [5, 5, 5], [0, 0, 0, 1], physicsClientId=world.client)
    assert arm.body_at(robot.end_effector_position()) is None


def test_body_at_finds_the_surface_the_subgoal_point_lies_on(world, robot):
    arm = ArmMotion(world.client, robot)
    box = add_box(world.client, [0.15, 0.15, 0.15], [0.9, 0.0, 0.65])
    assert arm.body_at(np.array([0.75, 0.0, 0.65])) == box  # on its -x face
    assert arm.body_at(np.array([0.5, 0.0, 0.65])) is None  # in the air before it


def test_a_push_starts_with_the_gripper_backed_out_to_contact(world, robot):
    arm, box = box_around_gripper(world, robot, depth=0.07)
    assert arm._gripper_penetration(box) > arm.config.gripper_penetration_allowance
    arm._back_out_of(box, np.array([1.0, 0.0, 0.0]))
    assert arm._gripper_penetration(box) <= arm.config.gripper_penetration_allowance


def test_the_first_plan_attempt_keeps_the_gripper_out_of_the_pushed_body_and_later_ones_let_it_in(
        world, robot, monkeypatch):
    from relmogen.motion_generation.ik import IKResult

    arm = ArmMotion(world.client, robot)
    box = add_box(world.client, [0.15, 0.15, 0.15], [0.9, 0.0, 0.65])
    seen = []

    def solve_ik(target, rng, from_current=True):
        seen.append(arm.checker.target_body)
        return IKResult(None, "IK solution in collision", 0.0, 1)

    monkeypatch.setattr(arm, "solve_ik", solve_ik)
    result = arm.reach_and_push(np.array([0.75, 0.0, 0.65]), PUSH, np.random.default_rng(0))
    assert not result.success and result.reason == "IK solution in collision"
    assert seen == [None, box], "strict first; one more IK with the exemption, then give up"
    assert arm.checker.target_body is None
