"""What ``gym.make`` gives beyond the step semantics: the spec's time limit and the state mode."""

import gymnasium as gym
import numpy as np
import pytest

import relmogen  # noqa: F401  (registers the ids)
from relmogen.envs.control_registry import CONTROL_NAMES
from relmogen.envs.relmogen_env import ROBOT_POSE_DIM
from relmogen.tasks import TASKS

# objects each task's state vector carries: (bodies, movable joints in all)
STATE_OBJECTS = {"PointNav": (0, 0), "TabletopReachM": (1, 0), "PushDoorNav": (1, 1), "ButtonDoorNav": (2, 2),
                 "InteractiveObstaclesNav": (2, 0), "ArrangeKitchenMM": (4, 8), "ArrangeChairMM": (3, 0)}
BODY_POSE_DIM = 5  # robot-frame x, y, z and cos, sin of the relative yaw


def expected_episode_steps(task: str, control: str) -> int:
    if control == "joint":
        return 750
    return 5 if task == "TabletopReachM" else 25


@pytest.mark.parametrize("control", CONTROL_NAMES)
@pytest.mark.parametrize("task", sorted(TASKS))
def test_spec_max_episode_steps_is_the_episode_length_of_the_control_made(task, control):
    env = gym.make(f"relmogen/{task}-v0", control=control, image_size=32)
    try:
        assert env.spec.max_episode_steps == expected_episode_steps(task, control)
        assert env.spec.kwargs["control"] == control
    finally:
        env.close()


def test_spec_follows_an_episode_steps_override_and_remakes_the_same_env():
    env = gym.make("relmogen/PointNav-v0", control="subgoal-r", image_size=32, episode_steps=3)
    remade = gym.make(env.spec)
    try:
        assert env.spec.max_episode_steps == remade.spec.max_episode_steps == 3
        remade.reset(seed=0)
        steps = 0
        truncated = terminated = False
        while not (terminated or truncated):
            _, _, terminated, truncated, _ = remade.step(np.zeros(remade.action_space.shape, np.float32))
            steps += 1
        assert steps <= 3
    finally:
        env.close()
        remade.close()


@pytest.mark.parametrize("task", sorted(TASKS))
def test_state_mode_observation_space_is_pose_task_vector_and_objects(task):
    env = gym.make(f"relmogen/{task}-v0", control="subgoal-r", image_size=32, obs_mode="state")
    try:
        bodies, joints = STATE_OBJECTS[task]
        dim = ROBOT_POSE_DIM + TASKS[task].task_obs_dim + BODY_POSE_DIM * bodies + joints
        assert set(env.observation_space.spaces) == {"state"}
        assert env.observation_space["state"].shape == (dim,)
        obs, _ = env.reset(seed=1)
        assert env.observation_space.contains(obs)
        x, y, yaw = env.unwrapped.robot.base_pose()
        np.testing.assert_allclose(obs["state"][:ROBOT_POSE_DIM], [x, y, np.cos(yaw), np.sin(yaw)], atol=1e-5)
        np.testing.assert_allclose(obs["state"][ROBOT_POSE_DIM:ROBOT_POSE_DIM + TASKS[task].task_obs_dim],
                                   env.unwrapped.task.task_obs(), atol=1e-5)
    finally:
        env.close()


def test_state_mode_keeps_the_controls_own_keys_and_steps_every_control():
    for control in CONTROL_NAMES:
        env = gym.make("relmogen/PushDoorNav-v0", control=control, image_size=32, obs_mode="state")
        try:
            obs, _ = env.reset(seed=2)
            obs, *_ = env.step(env.action_space.sample())
            assert env.observation_space.contains(obs)
            assert ("local_map" in obs) == (control == "subgoal-d")
        finally:
            env.close()


def test_state_mode_object_state_follows_the_door_hinge():
    env = gym.make("relmogen/PushDoorNav-v0", control="subgoal-r", image_size=32, obs_mode="state")
    try:
        env.reset(seed=3)
        task = env.unwrapped.task
        hinge = task.object_state()[-1]
        assert hinge == pytest.approx(task.door.angle, abs=1e-6)
    finally:
        env.close()


def test_unknown_obs_mode_names_the_valid_ones():
    with pytest.raises(ValueError, match="rgbd, state"):
        gym.make("relmogen/PointNav-v0", obs_mode="pixels")
