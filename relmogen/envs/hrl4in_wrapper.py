"""The robot's world state as an extra observation, for ``--algo hrl4in`` training.

HRL4IN's trainer measures its subgoals (base position, end-effector position) and the
low-level intrinsic reward on the robot's own state, which the policies never see. With
environments in worker processes that state has to travel with the observation:
``RobotStateObservation`` adds ``robot_state`` = ``(base x, base y, base yaw, end-effector x, y,
z)`` in the world frame (metres, radians) to every observation, including the terminal one SB3
keeps in ``info["terminal_observation"]``. ``relmogen.agents.hrl4in`` strips the key before
either policy sees the observation. Evaluation runs in-process and reads ``robot_state(env)``
directly, so the evaluation environment is the plain joint-velocity one of ``sac`` and ``oac``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
from gymnasium import spaces

ROBOT_STATE_KEY = "robot_state"
ROBOT_STATE_DIM = 6


def robot_state(env) -> np.ndarray:
    """``(x, y, yaw, ee_x, ee_y, ee_z)`` of a ``RelmogenEnv`` (or a wrapper of one), world frame."""
    robot = env.unwrapped.robot
    return np.concatenate([robot.base_pose(), robot.end_effector_position()]).astype(np.float32)


class RobotStateObservation(gym.ObservationWrapper):
    """Adds ``robot_state`` (see the module doc) to the observation dict."""

    def __init__(self, env: gym.Env):
        super().__init__(env)
        self.observation_space = spaces.Dict({
            **env.observation_space.spaces,
            ROBOT_STATE_KEY: spaces.Box(-np.inf, np.inf, (ROBOT_STATE_DIM,), np.float32),
        })

    def observation(self, observation: dict) -> dict:
        return {**observation, ROBOT_STATE_KEY: robot_state(self.env)}
