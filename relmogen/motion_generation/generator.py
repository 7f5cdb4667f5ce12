"""The motion generator (MG): turns one subgoal into a planned, checked, executed motion.

Base subgoal: (x, y, yaw) in the robot frame. The MG scans, builds the 5 m local occupancy
map, plans with the selected backend, then moves the base along the path kinematically (as
the original did), checking every waypoint against the FULL simulation and stopping before a
collision (a contact the robot started in may persist, no deeper, so that it can back away). Arm subgoal: a 3D point plus a horizontal push vector, handed to ``ArmMotion``.

Planners are selected by name and can be swapped at any time (``set_planners``): the policy
never sees which one runs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import pybullet as p

from relmogen.motion_generation.arm import ArmConfig, ArmMotion
from relmogen.motion_generation.base_planner import GOAL_MODES, make_base_planner, plan_base
from relmogen.motion_generation.planners import BACKENDS
from relmogen.simulation.contacts import Collision
from relmogen.simulation.frames import to_local
from relmogen.simulation.occupancy import LocalMap, build_local_map

DEPTH_TOLERANCE_M = 0.002  # contact depth a waypoint may add to a contact present at the start
BASE_SPEED = 0.5  # m/s while executing a base path (Fetch tops out at 1.0 m/s)
BASE_TURN_RATE = 1.0  # rad/s
ARM_JOINT_SPEED = 1.0  # rad/s of the fastest-moving joint while approaching an arm subgoal

Tick = Callable[[float], None]  # called with simulated seconds as execution advances


@dataclass
class MotionGeneratorConfig:
    base_planner: str = "rrt_connect"
    arm_planner: str = "rrt_connect"
    arm_collision_checking: bool = True  # the paper trains with False, evaluates with True
    base_goal: str = "strict"  # a base goal in collision: "strict" fails (paper); GOAL_MODES (ours)
    base_goal_clearance: float = 0.0  # m a base goal keeps from obstacles beyond the footprint (ours; 0: paper)
    map_size_m: float = 5.0
    map_resolution: float = 0.05
    arm: ArmConfig = field(default_factory=ArmConfig)

    def __post_init__(self):
        for name in (self.base_planner, self.arm_planner):
            if name not in BACKENDS:
                raise ValueError(f"unknown planner {name!r}; valid planners: {', '.join(sorted(BACKENDS))}")
        if self.base_goal not in GOAL_MODES:
            raise ValueError(f"unknown base_goal {self.base_goal!r}; valid: {', '.join(GOAL_MODES)}")


class WallSeconds(float):
    """A wall-clock duration. Measurements compare equal to one another: they describe the
    machine, not the simulation, so two runs with the same seed still give equal ``info``
    (Gymnasium's determinism check compares it). Arithmetic is plain float arithmetic."""

    def __eq__(self, other):
        return isinstance(other, WallSeconds) or float.__eq__(self, other)

    __hash__ = float.__hash__


@dataclass
class SubgoalResult:
    kind: str  # "base" or "arm"
    planner: str
    success: bool  # a plan was found and executed (possibly stopped early, see reason)
    reason: str
    planning_time_s: float = 0.0
    path_length_m: float = 0.0
    sim_time_s: float = 0.0

    def as_info(self) -> dict:
        return {
            "subgoal_type": self.kind,
            "planner": self.planner,
            "plan_found": self.success,
            "reason": self.reason,
            "planning_time_s": WallSeconds(self.planning_time_s),
            "path_length_m": self.path_length_m,
            "sim_time_s": self.sim_time_s,
        }


class MotionGenerator:
    def __init__(self, env, config: MotionGeneratorConfig | None = None):
        self.env = env
        self.config = config or MotionGeneratorConfig()
        self.arm = ArmMotion(env.world.client, env.robot, self._arm_config())
        self.set_planners(self.config.base_planner, self.config.arm_planner)

    def _arm_config(self) -> ArmConfig:
        from dataclasses import replace

        return replace(self.config.arm, collision_checking=self.config.arm_collision_checking)

    def set_planners(self, base: str | None = None, arm: str | None = None) -> None:
        """Swap planner backends by name; takes effect from the next subgoal."""
        if base is not None:
            self._base_planner = make_base_planner(base)
            self.config.base_planner = base
        if arm is not None:
            self.arm.set_planner(arm)
            self.config.arm_planner = arm

    def set_arm_collision_checking(self, enabled: bool) -> None:
        self.config.arm_collision_checking = bool(enabled)
        self.arm.config = self._arm_config()

    # -------------------------------------------------------------------------- base
    def local_map(self, ranges: np.ndarray | None = None, resolution: float | None = None) -> LocalMap:
        """The occupancy map of a scan (a fresh one unless ``ranges`` are given)."""
        env = self.env
        lidar_position, _ = env.robot.lidar_pose()
        pose = env.robot.base_pose()
        lidar_xy = tuple(to_local(np.asarray(lidar_position)[:2], pose))
        return build_local_map(
            env.scan() if ranges is None else ranges, env.lidar.angles, lidar_xy, env.lidar.max_range,
            tuple(pose), env.robot.spec.base_radius, self.config.map_size_m,
            resolution or self.config.map_resolution,
        )

    def move_base(self, goal_robot_frame: np.ndarray, rng: np.random.Generator, tick: Tick,
                  ranges: np.ndarray | None = None) -> SubgoalResult:
        """``ranges``: the scan to map, if one was taken where the robot stands (the paper plans
        on the most recent scan); a fresh scan otherwise."""
        planner = self.config.base_planner
        plan = plan_base(self.local_map(ranges), goal_robot_frame, self._base_planner,
                         self.env.robot.spec.base_radius, rng, goal_mode=self.config.base_goal,
                         goal_clearance=self.config.base_goal_clearance)
        if not plan.success:
            return SubgoalResult("base", planner, False, plan.reason, plan.planning_time_s)
        driven, sim_time, stopped_at = self._follow(plan.path_world, tick)
        reason = plan.reason if stopped_at is None else f"stopped before a collision at waypoint {stopped_at}"
        return SubgoalResult("base", planner, True, reason, plan.planning_time_s, driven, sim_time)

    def _follow(self, path: np.ndarray, tick: Tick) -> tuple[float, float, int | None]:
        """Move the base through ``path`` kinematically; stop at the last waypoint that touches
        nothing new and gets no deeper into what the robot already touched where it started (a
        door leaf pushed against the base must not pin the robot there for the whole episode)."""
        robot, client = self.env.robot, self.env.world.client
        driven = sim_time = 0.0
        previous = np.asarray(robot.base_pose(), dtype=np.float64)
        p.performCollisionDetection(physicsClientId=client)
        touching_at_start = contact_depths(self.env.collisions())
        for index, waypoint in enumerate(path[1:], start=1):
            robot.set_base_pose(*waypoint)
            p.performCollisionDetection(physicsClientId=client)
            if collides_beyond(self.env.collisions(), touching_at_start):
                robot.set_base_pose(*previous)
                return driven, sim_time, index
            step = float(np.hypot(*(waypoint[:2] - previous[:2])))
            turn = abs(float((waypoint[2] - previous[2] + np.pi) % (2 * np.pi) - np.pi))
            dt = step / BASE_SPEED + turn / BASE_TURN_RATE
            driven, sim_time, previous = driven + step, sim_time + dt, waypoint
            tick(dt)
        robot.stop_wheels()
        return driven, sim_time, None

    # --------------------------------------------------------------------------- arm
    def reach_and_push(self, point_world: np.ndarray, push_world: np.ndarray, rng: np.random.Generator,
                       tick: Tick) -> SubgoalResult:
        dt = self.env.world.time_step
        approach = {"time": 0.0}

        def reached(path) -> None:
            steps = np.abs(np.diff(np.asarray(path), axis=0)).max(axis=1) if len(path) > 1 else np.zeros(1)
            approach["time"] = float(steps.sum()) / ARM_JOINT_SPEED
            tick(approach["time"])

        result = self.arm.reach_and_push(point_world, push_world, rng, on_physics_steps=lambda n: tick(n * dt),
                                         on_reached=reached)
        return SubgoalResult("arm", self.config.arm_planner, result.success, result.reason,
                             result.planning_time_s, 0.0, approach["time"] + result.simulated_time_s)


def contact_depths(collisions: list[Collision]) -> dict[tuple[int, int], float]:
    """The deepest contact distance (m, <= 0) per touched (body, link)."""
    depths: dict[tuple[int, int], float] = {}
    for collision in collisions:
        key = (collision.other_body, collision.other_link)
        depths[key] = min(depths.get(key, 0.0), collision.distance)
    return depths


def collides_beyond(collisions: list[Collision], allowed: dict[tuple[int, int], float]) -> bool:
    """Whether ``collisions`` touch a (body, link) not in ``allowed`` or go deeper into one than
    its allowed depth (``contact_depths`` of the start) by more than ``DEPTH_TOLERANCE_M``."""
    return any(depth < allowed.get(key, np.inf) - DEPTH_TOLERANCE_M for key, depth in contact_depths(collisions).items())
