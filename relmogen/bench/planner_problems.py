"""The fixed, seeded problem suite of ``relmogen bench planner``, drawn from the real scenes.

Base problems (robot placed in the scene, one real LiDAR scan -> ``LocalMap`` through the
environment's motion generator, goal in the robot frame):

* ``open``      room centre, goal 1-2 m away along a line that is free on the floor plan;
* ``doorway``   robot ~1 m before a doorway of ``scene.doorways`` facing it, goal ~1 m beyond;
* ``cluttered`` start and goal in a furnished room with the straight line between them
                blocked on the floor plan (behind furniture, between desks);
* ``rotation``  same xy, different yaw.

Half of the base problems come from the office (``office_A``), half from the house (``house_A``).
The robot faces within 90 deg of the goal (the LiDAR sees 220 deg; behind the robot the map is
UNKNOWN), and candidates whose goal footprint is not free on the scan's map are redrawn: every
problem is one a policy could pick from the map, though a path need not exist.

Arm problems (goal configuration = one seeded, collision-free IK solution, start = tucked):

* ``table``     a point on the house ``reach_table`` top from a TabletopReachM start pose;
* ``door``      a point 0.8-1.2 m high on a temporary panel closing an office doorway, robot
                in front of it;
* ``cabinet``   a point on the front face of a temporary cabinet box against a kitchen wall.

Temporary bodies exist only while their problem is solved (``ArmProblem.scope``).
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np
import pybullet as p

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.motion_generation.base_planner import FootprintChecker, wrap_angle
from relmogen.scenes.geometry import Doorway
from relmogen.simulation.occupancy import LocalMap

BASE_CATEGORIES = ("open", "doorway", "cluttered", "rotation")
ARM_CATEGORIES = ("table", "door", "cabinet")
MAX_TRIES = 200
DOOR_STANDOFF = 0.65  # robot centre to the door panel, metres
CABINET_SIZE = (0.8, 0.6, 0.9)  # width along the wall, depth, height
CABINET_STANDOFF = 0.6  # robot centre to the cabinet front
PANEL_THICKNESS = 0.04


@dataclass
class BaseProblem:
    category: str
    scene: str
    local_map: LocalMap
    goal_robot: np.ndarray  # (x, y, yaw) in the robot frame at scan time
    seed: int


@dataclass
class ArmProblem:
    category: str
    target_world: np.ndarray
    goal_config: np.ndarray  # torso + 7 arm joints
    ik_attempts: int  # targets tried until IK found a collision-free solution
    seed: int


def make_envs(robot: str = "fetch") -> dict[str, RelmogenEnv]:
    """One office and one house environment, each with a motion generator (subgoal-r)."""
    return {"office": RelmogenEnv(task="PointNav", control="subgoal-r", image_size=32, robot=robot),
            "house": RelmogenEnv(task="TabletopReachM", control="subgoal-r", image_size=32,
                                 arm_collision=True, robot=robot)}


# ----------------------------------------------------------------------------- scene helpers


def clearance_at(env: RelmogenEnv, xy) -> float:
    """Floor-plan distance (m) from ``xy`` to the nearest static obstacle."""
    trav = env.scene.trav_map
    cell = trav.world_to_cell(np.asarray(xy, dtype=np.float64))
    if not bool(trav.in_grid(cell)):
        return 0.0
    return float(trav.clearance_grid()[cell[0], cell[1]])


def segment_clearance(env: RelmogenEnv, a, b, step: float = 0.05) -> float:
    """Smallest floor-plan clearance along the segment ``a``-``b``."""
    n = max(2, int(math.ceil(math.dist(a, b) / step)) + 1)
    return min(clearance_at(env, xy) for xy in np.linspace(a, b, n))


def robot_radius(env: RelmogenEnv) -> float:
    return env.robot.spec.base_radius


def place_robot(env: RelmogenEnv, xy, yaw: float) -> None:
    env.robot.reset((float(xy[0]), float(xy[1]), float(yaw)), head_tilt=env.task.head_tilt_angle())


Candidate = tuple[np.ndarray, float, np.ndarray, float]  # start xy, start yaw, goal xy, goal yaw


def heading(a, b) -> float:
    return math.atan2(b[1] - a[1], b[0] - a[0])


def observed_problem(env: RelmogenEnv, category: str, candidate: Candidate, seed: int) -> BaseProblem | None:
    """Place the robot, scan, and express the goal in the robot frame; None when the goal's
    footprint is not free on the scan's local map (unseen or occupied: no planner could)."""
    start_xy, start_yaw, goal_xy, goal_yaw = candidate
    place_robot(env, start_xy, start_yaw)
    local_map = env.control.mg.local_map()
    goal_xy_robot = local_map.world_to_robot(np.asarray(goal_xy, dtype=np.float64))
    goal = np.array([*goal_xy_robot, wrap_angle(goal_yaw - start_yaw)], dtype=np.float64)
    if FootprintChecker(local_map, robot_radius(env)).footprint_hits_obstacle(goal):
        return None
    return BaseProblem(category, env.scene.name, local_map, goal, seed)


# ----------------------------------------------------------------------------- base problems


def furnished_rooms(env: RelmogenEnv) -> list[str]:
    return [name for name in env.scene.regions if name != "corridor"]


def open_candidate(env: RelmogenEnv, rng: np.random.Generator) -> Candidate | None:
    """Room centre, goal 1-2 m away along a line with room to spare on the floor plan."""
    rooms = furnished_rooms(env)
    start = np.asarray(env.scene.regions[rooms[rng.integers(len(rooms))]].center) + rng.uniform(-0.3, 0.3, 2)
    angle, distance = rng.uniform(-np.pi, np.pi), rng.uniform(1.0, 2.0)
    goal = start + distance * np.array([np.cos(angle), np.sin(angle)])
    radius = robot_radius(env)
    if clearance_at(env, start) < radius + 0.2 or segment_clearance(env, start, goal) < radius + 0.1:
        return None
    return start, angle + rng.uniform(-0.5, 0.5) * np.pi, goal, rng.uniform(-np.pi, np.pi)


def _doorway_sides(doorway: Doorway, rng: np.random.Generator) -> tuple[str, str]:
    a, b = doorway.regions
    return (a, b) if rng.random() < 0.5 else (b, a)


def doorway_candidate(env: RelmogenEnv, rng: np.random.Generator) -> Candidate | None:
    """~1 m before a doorway, facing it; goal ~1 m beyond it."""
    doorway = env.scene.doorways[rng.integers(len(env.scene.doorways))]
    before, beyond = _doorway_sides(doorway, rng)
    start = doorway.point_in_front(before, rng.uniform(0.9, 1.1)) + doorway.along * rng.uniform(-0.3, 0.3)
    goal = doorway.point_in_front(beyond, rng.uniform(0.9, 1.1)) + doorway.along * rng.uniform(-0.3, 0.3)
    if min(clearance_at(env, start), clearance_at(env, goal)) < robot_radius(env) + 0.05:
        return None
    direction = heading(start, goal)
    return start, direction + rng.uniform(-0.3, 0.3), goal, direction + rng.uniform(-0.5, 0.5)


def cluttered_candidate(env: RelmogenEnv, rng: np.random.Generator) -> Candidate | None:
    """Start and goal 1-2.2 m apart in one furnished room, the straight line between them
    blocked on the floor plan (behind furniture, between desks)."""
    rooms, radius = furnished_rooms(env), robot_radius(env)
    room = rooms[rng.integers(len(rooms))]
    start = env.scene.sample_free_point(rng, room, clearance=radius + 0.1)
    goal = env.scene.sample_free_point(rng, room, clearance=radius + 0.1)
    if not 1.0 <= math.dist(start, goal) <= 2.2 or segment_clearance(env, start, goal) >= radius:
        return None
    return start, heading(start, goal) + rng.uniform(-0.5, 0.5) * np.pi, goal, rng.uniform(-np.pi, np.pi)


def rotation_candidate(env: RelmogenEnv, rng: np.random.Generator) -> Candidate | None:
    """Same xy, a turn of 0.5 to pi rad either way."""
    start = env.scene.sample_free_point(rng, clearance=robot_radius(env) + 0.1)
    yaw = rng.uniform(-np.pi, np.pi)
    return start, yaw, start, yaw + rng.choice([-1.0, 1.0]) * rng.uniform(0.5, np.pi)


CANDIDATES: dict[str, Callable[[RelmogenEnv, np.random.Generator], Candidate | None]] = {
    "open": open_candidate, "doorway": doorway_candidate, "cluttered": cluttered_candidate,
    "rotation": rotation_candidate,
}


def base_problem(env: RelmogenEnv, category: str, seed: int) -> BaseProblem:
    rng = np.random.default_rng(seed)
    for _ in range(MAX_TRIES * 10):
        candidate = CANDIDATES[category](env, rng)
        problem = candidate and observed_problem(env, category, candidate, seed)
        if problem is not None:
            return problem
    raise RuntimeError(f"no {category} problem in {env.scene.name} (seed {seed})")


def base_problems(envs: dict[str, RelmogenEnv], per_category: int, seed: int) -> list[BaseProblem]:
    """``per_category`` problems of each base category, alternating office and house."""
    return [base_problem(envs["office" if i % 2 == 0 else "house"], category, seed * 10_000 + c * 1_000 + i)
            for c, category in enumerate(BASE_CATEGORIES) for i in range(per_category)]


# ----------------------------------------------------------------------------- arm problems


@contextlib.contextmanager
def temporary_box(client: int, centre, half_extents, yaw: float) -> Iterator[int]:
    """A static box that exists only inside the ``with`` block."""
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=list(half_extents), physicsClientId=client)
    visual = p.createVisualShape(p.GEOM_BOX, halfExtents=list(half_extents), physicsClientId=client)
    body = p.createMultiBody(0.0, shape, visual, list(centre), p.getQuaternionFromEuler([0.0, 0.0, yaw]),
                             physicsClientId=client)
    try:
        yield body
    finally:
        p.removeBody(body, physicsClientId=client)


@dataclass
class ArmSetup:
    """Where the robot stands, the temporary box (or None) and a sampler of reach targets."""

    robot_pose: tuple[float, float, float]
    box: tuple[np.ndarray, np.ndarray, float] | None  # centre, half extents, yaw
    sample_target: Callable[[np.random.Generator], np.ndarray]


def table_setup(env: RelmogenEnv, rng: np.random.Generator) -> ArmSetup:
    """A TabletopReachM start pose; targets on the table top 0.45-0.95 m ahead, <= 0.4 m aside
    (the task's own goal distribution)."""
    env.reset(seed=int(rng.integers(1 << 30)))
    x, y, yaw = (float(v) for v in env.robot.base_pose())
    table = env.scene.reach_table
    forward, left = np.array([np.cos(yaw), np.sin(yaw)]), np.array([-np.sin(yaw), np.cos(yaw)])

    def sample(r: np.random.Generator) -> np.ndarray:
        for _ in range(MAX_TRIES):
            xy = np.array([x, y]) + r.uniform(0.45, 0.95) * forward + r.uniform(-0.4, 0.4) * left
            if table.footprint.contains(xy, margin=0.05):
                break
        return np.array([xy[0], xy[1], table.height])

    return ArmSetup((x, y, yaw), None, sample)


def door_setup(env: RelmogenEnv, rng: np.random.Generator) -> ArmSetup:
    radius, doorways = robot_radius(env), env.scene.doorways
    for _ in range(MAX_TRIES):
        doorway = doorways[rng.integers(len(doorways))]
        before, _ = _doorway_sides(doorway, rng)
        robot_xy = doorway.point_in_front(before, DOOR_STANDOFF)
        if clearance_at(env, robot_xy) > radius:
            break
    facing = np.asarray(doorway.center) - robot_xy
    facing /= np.linalg.norm(facing)
    yaw = math.atan2(facing[1], facing[0])
    centre = np.array([*doorway.center, 1.0])
    half = np.array([PANEL_THICKNESS / 2, doorway.width / 2, 1.0])
    face = np.asarray(doorway.center) - facing * PANEL_THICKNESS / 2

    def sample(r: np.random.Generator) -> np.ndarray:
        return np.array([*(face + doorway.along * r.uniform(-0.25, 0.25)), r.uniform(0.8, 1.2)])

    return ArmSetup((*robot_xy, yaw), (centre, half, float(doorway.yaw)), sample)


def cabinet_setup(env: RelmogenEnv, rng: np.random.Generator) -> ArmSetup:
    walls = env.scene.kitchen_walls
    wall = walls[rng.integers(len(walls))]
    width, depth, height = CABINET_SIZE
    normal = np.array([math.cos(wall.normal_yaw), math.sin(wall.normal_yaw)])
    on_wall = wall.point_at(rng.uniform(0.9, wall.length - 0.9))
    face = on_wall + normal * depth
    robot_xy = face + normal * CABINET_STANDOFF
    centre = np.array([*(on_wall + normal * depth / 2), height / 2])
    half = np.array([depth / 2, width / 2, height / 2])

    def sample(r: np.random.Generator) -> np.ndarray:
        return np.array([*(face + wall.direction * r.uniform(-0.3, 0.3)), r.uniform(0.45, 0.85)])

    return ArmSetup((*robot_xy, wall.normal_yaw + math.pi), (centre, half, float(wall.normal_yaw)), sample)


ARM_SETUPS: dict[str, tuple[str, Callable[[RelmogenEnv, np.random.Generator], ArmSetup]]] = {
    "table": ("house", table_setup), "door": ("office", door_setup), "cabinet": ("house", cabinet_setup),
}


@contextlib.contextmanager
def arm_problem(envs: dict[str, RelmogenEnv], category: str, seed: int,
                max_targets: int = 10) -> Iterator[tuple[RelmogenEnv, ArmProblem | None]]:
    """Set the scene up for one arm problem (robot pose, temporary box) and solve IK once.

    Yields the environment and the problem (None when no target within ``max_targets`` had a
    collision-free IK solution); the temporary box is removed on exit."""
    scene_kind, make_setup = ARM_SETUPS[category]
    env = envs[scene_kind]
    rng = np.random.default_rng(seed)
    setup = make_setup(env, rng)
    place_robot(env, setup.robot_pose[:2], setup.robot_pose[2])
    with contextlib.ExitStack() as stack:
        if setup.box is not None:
            stack.enter_context(temporary_box(env.world.client, *setup.box))
        yield env, _solve_ik(env, category, setup, rng, seed, max_targets)


def _solve_ik(env: RelmogenEnv, category: str, setup: ArmSetup, rng: np.random.Generator, seed: int,
              max_targets: int) -> ArmProblem | None:
    arm = env.control.mg.arm
    for attempt in range(1, max_targets + 1):
        target = setup.sample_target(rng)
        ik = arm.solve_ik(target, rng)
        if ik.config is not None:
            return ArmProblem(category, target, ik.config, attempt, seed)
    return None
