"""Scripted subgoal policies ("oracles") and the random-subgoal floor.

An oracle reads privileged simulator state (where the door hinge is, which obstacle is red,
which drawers are open, ...) but acts ONLY through the public ``subgoal-r`` action space: it
returns the same 8-D action a learned SGP-R policy would, and the environment's motion
generator executes it. It proves a task is solvable by the motion generator and gives the
ceiling for learning.

Helpers here turn world-frame intentions into actions:
``base_action(env, xy, yaw)`` drives toward a world pose (at most 2 m per subgoal) and
``arm_action(env, point, push)`` reaches a world point (visible in the current camera
frame) and pushes along a world-frame horizontal vector.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from relmogen.simulation.frames import to_local

if TYPE_CHECKING:
    from relmogen.envs.relmogen_env import RelmogenEnv

BASE_ANGLE_RANGE = np.deg2rad(110.0)
BASE_MAX_DISTANCE = 2.0
PUSH_MAX = 0.25


def wrap(angle: float) -> float:
    return float((angle + np.pi) % (2 * np.pi) - np.pi)


def base_action_robot_frame(x: float, y: float, yaw_change: float) -> np.ndarray:
    """subgoal-r action for a robot-frame target; targets beyond reach are shortened."""
    distance = float(np.hypot(x, y))
    angle = float(np.arctan2(y, x)) if distance > 1e-9 else 0.0
    if abs(angle) > BASE_ANGLE_RANGE:  # behind the robot: turn first, drive on the next step
        return np.array([1.0, 0.0, -1.0, np.clip(angle / np.pi, -1, 1), 0, 0, 0, 0], dtype=np.float32)
    distance = min(distance, BASE_MAX_DISTANCE)
    return np.array([1.0, angle / BASE_ANGLE_RANGE, distance - 1.0, wrap(yaw_change) / np.pi, 0, 0, 0, 0],
                    dtype=np.float32)


def base_action(env: RelmogenEnv, target_xy: np.ndarray, target_yaw: float | None = None) -> np.ndarray:
    """Drive toward a world xy (and final world yaw; default: face the direction of travel)."""
    pose = env.robot.base_pose()
    x, y, yaw = pose
    dx, dy = np.asarray(target_xy, dtype=np.float64) - (x, y)
    local = to_local(target_xy, pose)
    if target_yaw is None:
        target_yaw = float(np.arctan2(dy, dx)) if np.hypot(dx, dy) > 1e-6 else yaw
    return base_action_robot_frame(local[0], local[1], wrap(target_yaw - yaw))


def world_to_pixel(env: RelmogenEnv, point_world: np.ndarray) -> tuple[int, int] | None:
    """(row, col) where the current camera frame sees ``point_world``; None if out of view."""
    frame = env.last_frame
    local = frame.rotation.T @ (np.asarray(point_world) - frame.position)
    if local[0] <= 0.0:
        return None
    u, v, _ = env.camera.intrinsics.project(local)
    row, col = int(round(v)), int(round(u))
    h, w = frame.depth.shape
    return (row, col) if 0 <= row < h and 0 <= col < w else None


def arm_action_at_pixel(env: RelmogenEnv, row: int, col: int, push_world: np.ndarray) -> np.ndarray:
    h, w = env.last_frame.depth.shape
    yaw = env.robot.base_pose()[2]
    px, py = push_world[0], push_world[1]
    push_base = np.array([np.cos(yaw) * px + np.sin(yaw) * py, -np.sin(yaw) * px + np.cos(yaw) * py])
    norm = float(np.linalg.norm(push_base))
    if norm > PUSH_MAX:
        push_base *= PUSH_MAX / norm
    # Pixel centres: the inverse of row = int((a + 1) / 2 * H).
    a_row, a_col = (2.0 * (row + 0.5) / h) - 1.0, (2.0 * (col + 0.5) / w) - 1.0
    return np.array([-1.0, 0, 0, 0, a_row, a_col, *(push_base / PUSH_MAX)], dtype=np.float32)


def arm_action(env: RelmogenEnv, point_world: np.ndarray, push_world: np.ndarray) -> np.ndarray | None:
    """Reach the pixel that sees ``point_world`` and push; None when the point is not in view."""
    pixel = world_to_pixel(env, point_world)
    if pixel is None:
        return None
    return arm_action_at_pixel(env, *pixel, push_world)


class Oracle:
    """Base class: ``reset`` at the start of an episode, then ``act(obs)`` every step."""

    task_name: str

    def __init__(self, env: RelmogenEnv):
        self.env = env

    def reset(self) -> None:
        pass

    def act(self, obs: dict) -> np.ndarray:
        raise NotImplementedError


class RandomSubgoals(Oracle):
    """Uniform random subgoal-r actions: the floor that learning must beat."""

    def act(self, obs: dict) -> np.ndarray:
        return self.env.action_space.sample()


ORACLES: dict[str, type[Oracle]] = {}


def register_oracle(cls: type[Oracle]) -> type[Oracle]:
    ORACLES[cls.task_name] = cls
    return cls


def make_policy(kind: str, env: RelmogenEnv) -> Oracle:
    """``kind`` is ``oracle`` (the task's scripted policy) or ``random``."""
    if kind == "random":
        policy = RandomSubgoals(env)
        env.action_space.seed(int(env.np_random.integers(1 << 31)))
        return policy
    if kind != "oracle":
        raise ValueError(f"unknown policy {kind!r}; valid: oracle, random")
    task = env.task.name
    if task not in ORACLES:
        raise ValueError(f"no oracle for task {task!r}; oracles exist for: {', '.join(sorted(ORACLES))}")
    return ORACLES[task](env)

