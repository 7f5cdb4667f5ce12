"""Base motion planning in (x, y, yaw) on a LiDAR :class:`LocalMap`.

Planning happens in the robot frame at scan time (start = (0, 0, 0)); the result is returned
as world-frame waypoints. The robot is a disc of ``footprint_radius``; its clearance is read
from a distance transform of the obstacle cells (OCCUPIED and UNKNOWN, plus everything outside
the map window), so a collision check is one array lookup. Motion between configurations is
rotate-to-face-the-target, drive straight, rotate to the final yaw, at 0.05 m / 0.05 rad steps.

Compared with the original ReLMoGen base planner:

* a pure in-place rotation is returned at once (footprint is a disc: rotation never collides);
* the direct connection is tried first, so an empty room always plans;
* a start that already touches an obstacle (inflation, LiDAR noise, discretisation) can leave
  it: within one footprint radius of the start, a configuration is accepted when its clearance
  is at least the start's clearance (the robot may not get deeper into the obstacle, but may
  move along or away from it); beyond that radius full clearance is required;
* a goal outside the map window or whose footprint hits an obstacle fails immediately with
  ``reason`` "goal outside local map" / "goal in collision" (``goal_mode="strict"``, the
  paper's behaviour). ``goal_mode="nearest_free"`` (ours) instead moves a goal in collision
  back along the straight line from the robot to the nearest free pose, as a navigation
  stack's goal tolerance does, and plans there; ``goal_mode="nearest_reachable"`` (ours) moves
  it back along that line to the nearest pose that is free *and* connected to the robot, so that
  a goal behind a wall or outside a pocket the robot stands in still moves the robot toward it;
* ``goal_clearance`` (ours, default 0: the paper's) inflates the footprint for the goal pose only,
  as a navigation stack's inflation layer keeps the robot from parking against an obstacle: a goal
  that moves the base counts as in collision when it lies closer than that to an obstacle, and the
  goal modes above treat it so. Paths still need only the footprint's own clearance;
* a goal outside the start's 8-connected region of cells the disc may occupy fails before any
  search with "goal not connected to the robot on the local map" (no plan can exist: every step
  moves at most one cell). Random PushDoorNav subgoals: 26.8 -> 22.6 ms of CPU each, the time
  RRT-Connect spent on its restarts before giving up.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.ndimage import distance_transform_edt, label

from relmogen.motion_generation.planners import (
    Planner,
    PlanningProblem,
    RngLike,
    as_generator,
    make_planner,
)
from relmogen.simulation.occupancy import FREE, UNKNOWN, LocalMap

FETCH_FOOTPRINT_RADIUS = 0.279
# The LiDAR sees 220 deg from a point ahead of the base centre, so the space right beside and
# behind the robot is always UNKNOWN and would box it in. Unknown cells this close to the
# footprint count as free; every executed waypoint is still checked in the full simulation.
SELF_BLIND_MARGIN = 0.3
BASE_STEP_M = 0.05
BASE_STEP_RAD = 0.05
GOAL_MODES = ("strict", "nearest_free", "nearest_reachable")
# OMPL backends are time-limited; the base gets a shorter budget than the arm.
BASE_PLANNER_OVERRIDES: dict[str, dict] = {
    "ompl_rrtconnect": {"time_limit_s": 0.5},
    "ompl_prm": {"time_limit_s": 0.5},
    "lazy_prm": {"max_time_s": 2.0},  # solved base plans: 3 ms median, 0.16 s p95
}


def wrap_angle(a: float | np.ndarray) -> float | np.ndarray:
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


def make_base_planner(name: str, **overrides) -> Planner:
    """``make_planner`` with the base's defaults (shorter OMPL time limit)."""
    return make_planner(name, **{**BASE_PLANNER_OVERRIDES.get(name, {}), **overrides})


# ----------------------------------------------------------------------------- collision


class FootprintChecker:
    """Disc-footprint collision checks against a LocalMap, in the robot frame."""

    def __init__(self, local_map: LocalMap, footprint_radius: float) -> None:
        self.local_map = local_map
        self.radius = float(footprint_radius)
        self.clearance_grid = self._clearance_grid(local_map, self.radius)
        # Cell lookups are off by up to half a cell diagonal: tolerate that near the start.
        self.start_clearance = self.clearance((0.0, 0.0)) - 0.75 * local_map.resolution
        self._start_component: np.ndarray | None = None

    @staticmethod
    def _clearance_grid(local_map: LocalMap, radius: float) -> np.ndarray:
        obstacle = local_map.grid != FREE
        centres = local_map.cell_to_point(np.arange(local_map.size))
        near_robot = centres[:, None] ** 2 + centres[None, :] ** 2 <= (radius + SELF_BLIND_MARGIN) ** 2
        obstacle &= ~(near_robot & (local_map.grid == UNKNOWN))
        # One ring of obstacle cells around the window: the unseen outside counts as obstacle.
        padded = np.pad(obstacle, 1, constant_values=True)
        return distance_transform_edt(~padded)[1:-1, 1:-1] * local_map.resolution

    def clearance(self, xy: np.ndarray | tuple[float, float]) -> float:
        """Distance (m) from the cell under ``xy`` to the nearest obstacle cell; 0 outside the map."""
        # Scalar form of LocalMap.point_to_cell: this is the planners' inner loop.
        m = self.local_map
        i = math.floor((float(xy[0]) + m.half_extent) / m.resolution)
        j = math.floor((float(xy[1]) + m.half_extent) / m.resolution)
        if not (0 <= i < m.size and 0 <= j < m.size):
            return 0.0
        return float(self.clearance_grid[i, j])

    def connected_to_start(self, xy: np.ndarray | tuple[float, float]) -> bool:
        """Whether the cell under ``xy`` lies in the start cell's 8-connected component of cells
        the disc may occupy. Every plan moves in steps of at most one cell (``BASE_STEP_M`` is no
        larger than the map's resolution), so a goal outside it has no plan: no planner need
        search for one. Maps finer than the step are not checked (always True)."""
        m = self.local_map
        if m.resolution < BASE_STEP_M:
            return True
        if self._start_component is None:
            self._start_component = self._component_of_start()
        i, j = m.point_to_cell(np.asarray(xy[:2], dtype=np.float64))
        return bool(0 <= i < m.size and 0 <= j < m.size and self._start_component[i, j])

    def _component_of_start(self) -> np.ndarray:
        m = self.local_map
        centres = m.cell_to_point(np.arange(m.size))
        # Cells that in_collision may accept for some point inside them (a superset is safe).
        near_start = np.hypot(centres[:, None], centres[None, :]) <= self.radius + m.resolution
        may_occupy = (self.clearance_grid >= self.radius) | (near_start & (self.clearance_grid >= self.start_clearance))
        components, _ = label(may_occupy, structure=np.ones((3, 3), dtype=bool))
        i, j = m.point_to_cell(np.zeros(2))
        start_label = components[i, j]
        return components == start_label if start_label > 0 else np.zeros_like(may_occupy)

    def footprint_hits_obstacle(self, q: np.ndarray) -> bool:
        return self.clearance(q) < self.radius

    def in_collision(self, q: np.ndarray) -> bool:
        clearance = self.clearance(q)
        if clearance >= self.radius:
            return False
        near_start = math.hypot(q[0], q[1]) <= self.radius
        return not (near_start and clearance >= self.start_clearance)


# ----------------------------------------------------------------------------- extension


# Both build all their states in one array op (the planners call them thousands of times per
# plan); each state has the value of the scalar formula, e.g. yaw_from + delta * k / n.
def _rotation(xy: np.ndarray, yaw_from: float, yaw_to: float, step: float) -> list[np.ndarray]:
    """States after ``yaw_from`` up to ``yaw_to`` (shortest way), excluding the first."""
    delta = float(wrap_angle(yaw_to - yaw_from))
    n = int(math.ceil(abs(delta) / step - 1e-9))
    states = np.empty((n, 3))
    states[:, 0], states[:, 1] = xy[0], xy[1]
    states[:, 2] = wrap_angle(yaw_from + delta * np.arange(1, n + 1) / n)
    return list(states)


def _drive(xy_from: np.ndarray, xy_to: np.ndarray, yaw: float, step: float) -> list[np.ndarray]:
    """States after ``xy_from`` up to ``xy_to`` at constant ``yaw``, excluding the first."""
    n = int(math.ceil(np.linalg.norm(xy_to - xy_from) / step - 1e-9))
    states = np.empty((n, 3))
    states[:, :2] = xy_from + (xy_to - xy_from) * np.arange(1, n + 1)[:, None] / n
    states[:, 2] = yaw
    return list(states)


def _heading(q1: np.ndarray, q2: np.ndarray) -> float | None:
    d = q2[:2] - q1[:2]
    return None if np.hypot(*d) < 1e-6 else math.atan2(d[1], d[0])


def base_extend_fn(step_m: float = BASE_STEP_M, step_rad: float = BASE_STEP_RAD):
    """Rotate to face the target, drive straight, rotate to the target yaw (both ends included)."""

    def extend(q1: np.ndarray, q2: np.ndarray) -> list[np.ndarray]:
        q1, q2 = np.asarray(q1, dtype=np.float64), np.asarray(q2, dtype=np.float64)
        heading = _heading(q1, q2)
        path = [q1]
        if heading is not None:
            path += _rotation(q1[:2], q1[2], heading, step_rad)
            path += _drive(q1[:2], q2[:2], heading, step_m)
        path += _rotation(path[-1][:2], path[-1][2], q2[2], step_rad)
        if len(path) == 1:
            path.append(q2)
        return path

    return extend


def base_distance_fn(step_m: float = BASE_STEP_M, step_rad: float = BASE_STEP_RAD):
    """Cost of ``base_extend_fn``'s motion: metres driven plus rotation weighted so that one
    angular step costs as much as one linear step (i.e. proportional to the number of steps).
    Scalar ``math`` on purpose: RRT's nearest-neighbour scan calls this thousands of times."""
    rotation_weight = step_m / step_rad

    def turn(a: float) -> float:
        return abs((a + math.pi) % (2.0 * math.pi) - math.pi)

    def distance(q1: np.ndarray, q2: np.ndarray) -> float:
        x1, y1, yaw1 = (float(v) for v in q1)
        x2, y2, yaw2 = (float(v) for v in q2)
        dx, dy = x2 - x1, y2 - y1
        drive = math.hypot(dx, dy)
        if drive < 1e-6:
            return rotation_weight * turn(yaw2 - yaw1)
        heading = math.atan2(dy, dx)
        return drive + rotation_weight * (turn(heading - yaw1) + turn(yaw2 - heading))

    return distance


# ----------------------------------------------------------------------------- planning


@dataclass(frozen=True)
class BasePlanResult:
    path_world: np.ndarray | None  # (N, 3) world (x, y, yaw), <= 0.05 m / 0.05 rad apart
    reason: str
    planning_time_s: float
    path_length_m: float  # distance driven (rotations excluded); 0 on failure
    backend: str

    @property
    def success(self) -> bool:
        return self.path_world is not None


def base_planning_problem(
    local_map: LocalMap, goal_robot: np.ndarray, checker: FootprintChecker
) -> PlanningProblem:
    """The robot-frame (x, y, yaw) problem over the whole map window."""
    reach = local_map.half_extent
    return PlanningProblem(
        start=np.zeros(3),
        goal=np.asarray(goal_robot, dtype=np.float64),
        lower=np.array([-reach, -reach, -np.pi]),
        upper=np.array([reach, reach, np.pi]),
        collision_fn=checker.in_collision,
        resolutions=np.array([BASE_STEP_M, BASE_STEP_M, BASE_STEP_RAD]),
        extend_fn=base_extend_fn(),
        distance_fn=base_distance_fn(),
    )


def plan_base(
    local_map: LocalMap,
    goal_xy_yaw_robot_frame: np.ndarray | tuple[float, float, float],
    planner: Planner | str = "rrt_connect",
    footprint_radius: float = FETCH_FOOTPRINT_RADIUS,
    rng: RngLike = None,
    goal_mode: str = "strict",
    goal_clearance: float = 0.0,
) -> BasePlanResult:
    """Plan the base from the robot's pose at scan time to a robot-frame goal (x, y, yaw);
    ``goal_mode`` says what a goal in collision does, ``goal_clearance`` (m) how far from obstacles
    a goal must stay beyond the footprint (module doc)."""
    if goal_mode not in GOAL_MODES:
        raise ValueError(f"unknown goal_mode {goal_mode!r}; valid: {', '.join(GOAL_MODES)}")
    if not (math.isfinite(goal_clearance) and goal_clearance >= 0.0):
        raise ValueError(f"goal_clearance must be a finite distance >= 0 m, got {goal_clearance!r}")
    start_time = time.perf_counter()
    planner = make_base_planner(planner) if isinstance(planner, str) else planner
    goal = np.asarray(goal_xy_yaw_robot_frame, dtype=np.float64).copy()
    goal[2] = wrap_angle(goal[2])

    def result(path_robot: list[np.ndarray] | None, reason: str) -> BasePlanResult:
        elapsed = time.perf_counter() - start_time
        if path_robot is None:
            return BasePlanResult(None, reason, elapsed, 0.0, planner.backend)
        path = np.asarray(path_robot)
        length = float(np.sum(np.linalg.norm(np.diff(path[:, :2], axis=0), axis=1)))
        return BasePlanResult(_to_world(local_map, path), reason, elapsed, length, planner.backend)

    if not bool(local_map.contains(goal[:2])):
        return result(None, "goal outside local map")
    checker = FootprintChecker(local_map, footprint_radius)
    goal_free = goal_free_fn(checker, goal_clearance)
    note = ""
    if goal_mode == "nearest_reachable":
        reachable = lambda q: goal_free(q) and checker.connected_to_start(q)  # noqa: E731
        if not reachable(goal):
            requested = float(np.hypot(goal[0], goal[1]))
            goal = nearest_goal_on_line(goal, reachable)
            note = f"goal unreachable, moved {requested - float(np.hypot(goal[0], goal[1])):.2f} m back; "
    elif not goal_free(goal):
        if goal_mode == "strict":
            return result(None, "goal in collision")
        requested = float(np.hypot(goal[0], goal[1]))
        goal = nearest_goal_on_line(goal, goal_free)
        note = f"goal in collision, moved {requested - float(np.hypot(goal[0], goal[1])):.2f} m back; "
    if np.hypot(goal[0], goal[1]) < 1e-6:
        return result(base_extend_fn()(np.zeros(3), goal), note + "rotation in place")
    if not checker.connected_to_start(goal):
        return result(None, note + "goal not connected to the robot on the local map")
    plan = planner.plan(base_planning_problem(local_map, goal, checker), as_generator(rng))
    return result(plan.path, note + plan.reason)


def goal_free_fn(checker: FootprintChecker, goal_clearance: float) -> Callable[[np.ndarray], bool]:
    """Whether a goal pose is acceptable: out of collision and, when it moves the base, at least
    ``goal_clearance`` beyond the footprint from every obstacle (a rotation in place always is)."""
    required = checker.radius + goal_clearance

    def goal_free(q: np.ndarray) -> bool:
        if checker.in_collision(q):
            return False
        return goal_clearance <= 0.0 or math.hypot(q[0], q[1]) < 1e-6 or checker.clearance(q) >= required

    return goal_free


def nearest_goal_on_line(goal: np.ndarray, accept: Callable[[np.ndarray], bool]) -> np.ndarray:
    """The accepted pose nearest ``goal`` on the straight line from the robot (0, 0) to it, with
    the goal's yaw; the start itself (a rotation in place) when no pose on the line is accepted."""
    distance = float(np.hypot(goal[0], goal[1]))
    for along in np.arange(distance, 0.0, -BASE_STEP_M):
        candidate = np.array([goal[0] * along / distance, goal[1] * along / distance, goal[2]])
        if accept(candidate):
            return candidate
    return np.array([0.0, 0.0, goal[2]])


def _to_world(local_map: LocalMap, path_robot: np.ndarray) -> np.ndarray:
    xy = local_map.robot_to_world(path_robot[:, :2])
    yaw = wrap_angle(path_robot[:, 2] + local_map.robot_pose[2])
    return np.column_stack([xy, yaw])
