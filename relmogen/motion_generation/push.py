"""Executing a Cartesian push with physics while the mobile base is held still.

The arm follows precomputed joint targets under position control with high force; the base is
pinned to the world by a temporary fixed constraint (and its wheels told to stand still), so the
reaction of whatever is pushed cannot move the robot.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
import pybullet as p

from relmogen.robots.robot import Robot

PhysicsCallback = Callable[[int], None]


@dataclass(frozen=True)
class PushLine:
    start: np.ndarray  # world point where the push begins
    direction: np.ndarray  # unit vector
    length: float  # metres, already clipped

    def points(self, count: int) -> np.ndarray:
        """``count`` points after ``start`` up to the end of the line, evenly spaced."""
        fractions = np.arange(1, count + 1) / count
        return self.start + np.outer(fractions * self.length, self.direction)

    def progress(self, position: np.ndarray) -> float:
        """Distance travelled along the line by a point that started at ``start``."""
        return float(np.dot(np.asarray(position) - self.start, self.direction))


def make_push_line(start: np.ndarray, push_vector: np.ndarray, max_length: float) -> PushLine:
    vector = np.asarray(push_vector, dtype=np.float64)
    norm = float(np.linalg.norm(vector))
    direction = vector / norm if norm > 0 else np.zeros(3)
    return PushLine(np.asarray(start, dtype=np.float64), direction, min(norm, max_length))


@contextlib.contextmanager
def base_held_still(client: int, robot: Robot, max_force: float) -> Iterator[None]:
    """Pin the base where it is (fixed constraint to the world) for the duration of the block."""
    body = robot.robot_id
    position, orientation = p.getBasePositionAndOrientation(body, physicsClientId=client)
    p.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0], physicsClientId=client)
    wheels = robot.wheel_joint_indices.tolist()
    p.setJointMotorControlArray(body, wheels, p.VELOCITY_CONTROL, targetVelocities=[0.0] * len(wheels),
                                forces=robot.joint_max_force[wheels].tolist(), physicsClientId=client)
    constraint = p.createConstraint(body, -1, -1, -1, p.JOINT_FIXED, [0, 0, 0], [0, 0, 0], position,
                                    childFrameOrientation=orientation, physicsClientId=client)
    p.changeConstraint(constraint, maxForce=max_force, physicsClientId=client)
    try:
        yield
    finally:
        p.removeConstraint(constraint, physicsClientId=client)
        p.resetBaseVelocity(body, [0, 0, 0], [0, 0, 0], physicsClientId=client)


@contextlib.contextmanager
def physics_sub_steps(client: int, sub_steps: int | None) -> Iterator[None]:
    """Step the world with ``sub_steps`` sub-steps inside the block (None: leave it as it is)."""
    if sub_steps is None:
        yield
        return
    saved = p.getPhysicsEngineParameters(physicsClientId=client)["numSubSteps"]
    p.setPhysicsEngineParameter(numSubSteps=int(sub_steps), physicsClientId=client)
    try:
        yield
    finally:
        p.setPhysicsEngineParameter(numSubSteps=saved, physicsClientId=client)


def follow_joint_targets(client: int, robot: Robot, targets: np.ndarray, forces: np.ndarray,
                         position_gain: float, steps_per_target: int,
                         on_physics_steps: PhysicsCallback | None = None) -> int:
    """Command each row of ``targets`` in turn and step physics; returns the steps taken."""
    steps = 0
    for q in targets:
        robot.command_joint_positions(robot.arm_joint_indices, q, max_force=forces, position_gain=position_gain)
        steps += step_physics(client, steps_per_target, on_physics_steps)
    return steps


def step_physics(client: int, n_steps: int, on_physics_steps: PhysicsCallback | None = None) -> int:
    for _ in range(n_steps):
        p.stepSimulation(physicsClientId=client)
    if on_physics_steps is not None and n_steps > 0:
        on_physics_steps(n_steps)
    return n_steps
