"""ButtonDoorNav: the locked door, the button, what opens the door, physics stability."""

import math
import os

import numpy as np
import pybullet as p
import pytest
from door_helpers import drive_forward_until_done

from relmogen.agents.oracles.base import arm_action, base_action
from relmogen.agents.oracles.push_door_nav import plan_stroke
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.scenes.objects.door import BUTTON_TRAVEL, DOOR_LIMITS, OPEN_ANGLE
from relmogen.tasks.button_door_nav import button_cap_cells


@pytest.fixture(scope="module")
def subgoal_env():
    env = RelmogenEnv(task="ButtonDoorNav", control="subgoal-r", image_size=64)
    yield env
    env.close()


@pytest.fixture(scope="module")
def joint_env():
    env = RelmogenEnv(task="ButtonDoorNav", control="joint", image_size=64)
    yield env
    env.close()


def place_robot(env, xy, yaw) -> None:
    env.robot.reset((*xy, yaw), head_tilt=env.task.head_tilt_angle())
    env.task.after_reset()
    env._observe()  # the arm subgoal reads the camera frame of the new pose


def face_door(env, distance: float, along: float = 0.0) -> None:
    doorway = env.task.doorway
    normal = np.asarray(doorway.normal)
    xy = np.asarray(doorway.center) - distance * normal + along * np.asarray(doorway.along)
    place_robot(env, xy, math.atan2(normal[1], normal[0]))


def face_button(env, distance: float = 0.65) -> None:
    button = env.task.button
    place_robot(env, button.face_xy + distance * button.out_normal,
                math.atan2(-button.out_normal[1], -button.out_normal[0]))


def press_action(env, length: float = 0.2):
    button = env.task.button
    return arm_action(env, button.face_centre(), -length * np.append(button.out_normal, 0.0))


@pytest.mark.parametrize("scene", ["office_A", "office_B"])
def test_button_is_on_the_corridor_wall_next_to_the_door(scene):
    env = RelmogenEnv(task="ButtonDoorNav", control="joint", scene=scene, image_size=64)
    task, doorway, sides = env.task, env.task.doorway, set()
    for seed in range(12):
        env.reset(seed=seed)
        button = task.button
        offset = float(np.dot(button.face_xy - doorway.center, doorway.along))
        assert 0.3 - 1e-6 <= abs(offset) - 0.5 * doorway.width <= 1.0 + 1e-6
        assert 0.9 <= button.height <= 1.1
        assert env.scene.region_of(button.face_xy + 0.3 * button.out_normal) == env.scene.start_region
        assert button.depth == pytest.approx(0.0, abs=1e-9) and not task.button_pressed()
        assert task.door.angle == pytest.approx(0.0, abs=1e-9)
        assert np.linalg.norm(env.robot.base_pose()[:2] - button.face_xy) >= 0.7
        p.performCollisionDetection(physicsClientId=env.world.client)
        assert not env.collisions()
        sides.add(np.sign(offset))
    assert sides == {1.0, -1.0}
    env.close()


def test_driving_into_the_locked_door_terminates_on_collision(joint_env):
    joint_env.reset(seed=0)
    face_door(joint_env, 0.6)
    terminated, info = drive_forward_until_done(joint_env)
    assert terminated and info["termination"] == "collision"
    assert abs(joint_env.task.door.angle) < 0.01  # the lock motor holds against the base


def test_base_subgoals_cannot_open_the_door(subgoal_env):
    subgoal_env.reset(seed=1)
    face_door(subgoal_env, 0.8)
    target = np.asarray(subgoal_env.task.doorway.center) + 1.2 * np.asarray(subgoal_env.task.doorway.normal)
    for _ in range(3):
        subgoal_env.step(base_action(subgoal_env, target, subgoal_env.task.doorway.yaw))
    assert abs(subgoal_env.task.door.angle) < 1e-3
    assert subgoal_env.scene.region_of(subgoal_env.robot.base_pose()[:2]) == subgoal_env.scene.start_region


def test_pushing_the_locked_door_with_the_arm_does_not_open_it(subgoal_env):
    subgoal_env.reset(seed=2)
    stroke = plan_stroke(subgoal_env.task.door)
    place_robot(subgoal_env, stroke.base_xy, stroke.base_yaw)
    _, _, _, _, info = subgoal_env.step(arm_action(subgoal_env, stroke.point, stroke.push))
    assert info["plan_found"], info["reason"]
    assert abs(subgoal_env.task.door.angle) < 0.01
    assert not subgoal_env.task.button_pressed()


def test_pressing_the_button_opens_the_door_within_the_same_step(subgoal_env):
    for seed in range(3, 10):  # a press can miss (IK, a glancing contact): the first that lands
        subgoal_env.reset(seed=seed)
        face_button(subgoal_env)
        _, reward, _, _, info = subgoal_env.step(press_action(subgoal_env))
        if subgoal_env.task.button_pressed():
            break
    task = subgoal_env.task
    assert task.button_pressed(), info["reason"]
    assert task.door.angle > math.radians(85.0) and task.door.is_open()
    assert info["reward_terms"]["button"] == 5.0
    _, _, _, _, info = subgoal_env.step(press_action(subgoal_env))  # pressing again pays nothing
    assert info["reward_terms"].get("button", 0.0) == 0.0
    assert task.metrics()["button_pressed"] == 1.0 and task.metrics()["door_opened"] == 1.0


def test_a_press_at_the_very_end_of_a_push_still_opens_the_door(joint_env):
    joint_env.reset(seed=4)
    task = joint_env.task
    p.resetJointState(task.button.body, 0, 0.04, 0.0, physicsClientId=joint_env.world.client)
    task.after_control_step()  # the press is seen; then only kinematic motion follows
    assert task.button_pressed() and task.door.angle < 0.01
    task.after_control_step()
    assert task.door.angle > OPEN_ANGLE


def test_the_spring_returns_the_button(joint_env):
    joint_env.reset(seed=5)
    client = joint_env.world.client
    p.resetJointState(joint_env.task.button.body, 0, 0.02, 0.0, physicsClientId=client)
    joint_env.world.step(40)
    assert joint_env.task.button.depth < 0.003


def random_joint_steps_stay_physical(env, steps: int, seed: int = 0) -> None:
    """Random joint velocities; alternate episodes start at the door or at the button."""
    rng = np.random.default_rng(seed)
    client, task = env.world.client, env.task
    bounds, episode = env.scene.bounds, 0
    env.reset(seed=seed)
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, env.action_space.shape))
        assert np.all(np.isfinite(env.robot.base_pose()))
        for body, z_range in ((task.door.body, (0.5, 1.6)), (task.button.body, (0.8, 1.2))):
            position = p.getLinkState(body, 0, physicsClientId=client)[0]
            assert np.all(np.isfinite(position))
            assert bounds.xmin - 0.5 <= position[0] <= bounds.xmax + 0.5
            assert bounds.ymin - 0.5 <= position[1] <= bounds.ymax + 0.5
            assert z_range[0] < position[2] < z_range[1]
        assert DOOR_LIMITS[0] - 0.05 <= task.door.angle <= DOOR_LIMITS[1] + 0.05
        assert -0.01 <= task.button.depth <= BUTTON_TRAVEL + 0.01
        if terminated or truncated:
            episode += 1
            env.reset(seed=seed + episode)
            if episode % 3 == 1:
                face_door(env, rng.uniform(0.45, 0.8), rng.uniform(-0.3, 0.3))
            elif episode % 3 == 2:
                face_button(env, rng.uniform(0.45, 0.7))


def test_random_joint_steps_keep_door_and_button_physical(joint_env):
    random_joint_steps_stay_physical(joint_env, 500)


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get("RELMOGEN_SLOW") != "1", reason="slow: set RELMOGEN_SLOW=1")
def test_random_joint_steps_keep_door_and_button_physical_long(joint_env):
    random_joint_steps_stay_physical(joint_env, 10_000)


def test_button_cap_cells_mark_the_blocks_with_red_cap_pixels_in_either_channel_layout():
    rgb = np.full((1, 16, 16, 3), 200, np.uint8)
    rgb[0, 5, 9] = (230, 10, 10)  # one cap pixel in block (1, 2) of 4 x 4 pixels
    rgb[0, 12, 0] = (230, 90, 10)  # orange, not the cap
    expected = np.zeros((1, 4, 4), bool)
    expected[0, 1, 2] = True
    np.testing.assert_array_equal(button_cap_cells(rgb, 4), expected)
    np.testing.assert_array_equal(button_cap_cells(rgb.transpose(0, 3, 1, 2), 4), expected)
