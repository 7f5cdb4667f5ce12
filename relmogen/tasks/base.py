"""The task interface and the task registry.

A task owns what makes an episode: its objects (created once, in ``load``), the episode
randomisation (``reset``), the task observation vector, the reward terms, success, and the
episode metrics. It never reloads the scene and never touches the environment class.

Hooks, in the order the environment calls them:
``load()`` once -> per episode ``reset(rng)`` -> per 0.1 s control step ``after_control_step()``
and the reward terms -> ``is_success()`` -> ``metrics()`` when the episode ends.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from relmogen.simulation.bodies import body_pose_and_joints
from relmogen.simulation.frames import to_local
from relmogen.tasks.terms import RewardTerm

if TYPE_CHECKING:
    from relmogen.robots.robot import Robot
    from relmogen.scenes import Scene
    from relmogen.simulation.world import World


@dataclass
class TaskContext:
    """The simulated things a task may use."""

    world: World
    scene: Scene
    robot: Robot


class Task:
    """Base class; subclasses fill in the class attributes and the hooks."""

    name: ClassVar[str]
    scene_kind: ClassVar[str]  # "office" or "house": scenes of this kind can host the task
    head_tilt: ClassVar[str] = "navigation"  # which tilt of the robot spec the head uses
    subgoal_steps: ClassVar[int] = 25  # episode length with subgoal controls
    joint_steps: ClassVar[int] = 750  # episode length with joint-velocity control
    subgoal_parts: ClassVar[tuple[str, ...]] = ("base", "arm")  # what the subgoal policy may use
    task_obs_dim: ClassVar[int]
    has_map_marks: ClassVar[bool] = False  # draws goal/waypoints on the SGP-D local map

    def __init__(self, ctx: TaskContext):
        self.ctx = ctx
        self.reward_terms: list[RewardTerm] = []

    # ----------------------------------------------------------------------------- hooks
    def load(self) -> None:
        """Create the task's own bodies (markers, doors, ...). Called once."""

    def reset(self, rng: np.random.Generator) -> None:
        """Randomise the episode: robot start, goal, object poses. No scene reload."""
        raise NotImplementedError

    def after_reset(self) -> None:
        for term in self.reward_terms:
            term.reset()

    def after_control_step(self) -> None:
        """Book-keeping after each 0.1 s of simulated time (path length, ...)."""

    def reward(self, decision: bool = True) -> tuple[float, dict[str, float]]:
        """Sum of the reward terms; per-decision terms only when ``decision`` is true."""
        parts = {term.name: term() for term in self.reward_terms if decision or not term.per_decision}
        return float(sum(parts.values())), parts

    def task_obs(self) -> np.ndarray:
        raise NotImplementedError

    def object_bodies(self) -> list[int]:
        """The PyBullet bodies of the task's objects (door, button, boxes, cabinets, chairs, a
        marker the robot must find) whose poses the ``state`` observation carries; none by default."""
        return []

    def object_state(self) -> np.ndarray:
        """For each of ``object_bodies()``: its position in the robot frame, its yaw relative to
        the robot as (cos, sin), and the positions of its movable joints (door hinge, drawer slide)."""
        parts = [self._body_state(body) for body in self.object_bodies()]
        return np.concatenate(parts).astype(np.float32) if parts else np.zeros(0, np.float32)

    def _body_state(self, body: int) -> np.ndarray:
        position, yaw, joints = body_pose_and_joints(self.ctx.world.client, body)
        relative_yaw = yaw - self.ctx.robot.base_pose()[2]
        return np.concatenate([self.to_robot_frame(position), [np.cos(relative_yaw), np.sin(relative_yaw)], joints])

    def is_success(self) -> bool:
        raise NotImplementedError

    def terminates_on_success(self) -> bool:
        return True

    def map_marks(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Robot-frame points and uint8 values to draw on the local map for SGP-D (goal and
        waypoints for navigation tasks); None when the task gives no such information."""
        return None

    def metrics(self) -> dict[str, float]:
        """Episode metrics with the project-wide keys (``success``, ``spl``, ``closed_5``...)."""
        return {"success": float(self.is_success())}

    # ------------------------------------------------------------------ shared pieces
    def sample_free_point(self, rng: np.random.Generator, region=None) -> np.ndarray:
        """A free floor point of the scene (in ``region``) with room for this robot's base: its
        radius plus ``FREE_POINT_MARGIN`` from every obstacle."""
        from relmogen.scenes.navigation import FREE_POINT_MARGIN

        return self.ctx.scene.sample_free_point(rng, region, clearance=self.ctx.robot.spec.base_radius
                                                + FREE_POINT_MARGIN)

    def head_tilt_angle(self) -> float:
        return float(getattr(self.ctx.robot.spec, f"head_tilt_{self.head_tilt}"))

    def proprioception(self) -> np.ndarray:
        """End effector xyz (robot frame) + 8 joint positions + sin/cos of the 7 arm joints +
        8 joint velocities: the 33 robot entries of the original 55-D task vector."""
        robot = self.ctx.robot
        positions, velocities = robot.joint_state_vector()
        ee = self.to_robot_frame(robot.end_effector_position())
        arm = positions[1:]
        return np.concatenate([ee, positions, np.sin(arm), np.cos(arm), velocities]).astype(np.float32)

    def to_robot_frame(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 2 or 3) -> the robot base frame (z measured from the floor)."""
        pts = np.asarray(points, dtype=np.float64)
        planar = to_local(pts, self.ctx.robot.base_pose())
        return np.concatenate([planar, pts[..., 2:3]], axis=-1) if pts.shape[-1] == 3 else planar


TASKS: dict[str, type[Task]] = {}


def register_task(cls: type[Task]) -> type[Task]:
    """Class decorator: adds the task to the registry (the gymnasium ids follow from it)."""
    TASKS[cls.name] = cls
    return cls


def task_class(name: str) -> type[Task]:
    if name not in TASKS:
        raise ValueError(f"unknown task {name!r}; valid tasks: {', '.join(sorted(TASKS))}")
    return TASKS[name]
