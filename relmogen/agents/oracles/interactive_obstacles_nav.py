"""InteractiveObstaclesNav oracle: push the red box deeper into the room, then drive to the goal.

Privileged knowledge: which box is red and where both boxes and the goal are. Loop:
while a base (3 cm fatter than Fetch) cannot reach the goal past the boxes, stand in front of
the red box's face that looks at the doorway and push it 0.25 m along that face's normal
(further into the goal room, which widens the strip between the wall and the box); once the
way is open, follow the shortest path on the floor plan WITH the boxes in it.
"""

from __future__ import annotations

import numpy as np

from relmogen.agents.oracles.base import (
    Oracle,
    arm_action,
    base_action,
    register_oracle,
    wrap,
)
from relmogen.scenes.navigation import GeodesicField, TraversabilityMap
from relmogen.simulation.frames import to_local
from relmogen.tasks.interactive_obstacles_nav import PUSH_LENGTH

PUSH_HEIGHTS = (0.65, 0.6, 0.75)  # m on the box face (tipping starts above ~1.1 m); cycled on failures
STAND_OFF = np.arange(0.45, 0.95, 0.05)  # base centre to the pushed face, metres
# The arm planner (20 RRT-Connect iterations) finds a path from the tucked pose most often
# when the face is 0.8-0.9 m ahead of the base centre and the push point low (measured at
# the doorways: about half of the attempts).
PREFERRED_STAND_OFF = 0.85
SIDE_OFFSETS = np.arange(-0.3, 0.31, 0.05)  # base centre across the face normal
BASE_MARGIN = 0.07  # extra clearance of a push pose from walls and boxes
ARM_TRIES_PER_POSE = 3  # failed subgoals before trying the next push pose
POSE_CHOICES = 3
POSE_TOLERANCE = (0.08, 0.12)  # m, rad: close enough to the push pose to push
LOOKAHEADS = (10, 7, 4, 2)  # waypoints (0.2 m apart) to aim at; shorter after a failed plan
ESCAPE_AFTER = 4  # failed subgoals in a row before driving somewhere clear at random
TURN_FIRST = 1.2  # rad: hops further off the heading than this are turned to first (LiDAR view)
PATH_MARGIN = 0.06  # m: the oracle's paths keep this much more than the base radius


def box_face(xy: np.ndarray, yaw: float, half: float, toward: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre of the box face whose outward normal points most along ``toward`` (unit xy),
    and the unit vector INTO the box through that face (the push direction)."""
    axes = np.array([[np.cos(yaw), np.sin(yaw)], [-np.sin(yaw), np.cos(yaw)]])
    scores = axes @ toward
    k = int(np.argmax(np.abs(scores)))
    outward = axes[k] * np.sign(scores[k])
    return xy + half * outward, -outward


def distance_to_box(points: np.ndarray, xy: np.ndarray, yaw: float, half: float) -> np.ndarray:
    local = to_local(points, (*np.asarray(xy)[:2], yaw))
    return np.linalg.norm(np.maximum(np.abs(local) - half, 0.0), axis=-1)


@register_oracle
class InteractiveObstaclesNavOracle(Oracle):
    task_name = "InteractiveObstaclesNav"

    def reset(self) -> None:
        self._attempt = 0  # subgoals in a row that moved neither the robot nor the red box
        self._arm_failures = 0  # arm subgoals since the red box last moved
        self._pushed = False  # the previous action was an arm subgoal
        self._last_state = None
        self._field_key = None
        self._field: GeodesicField | None = None

    # ------------------------------------------------------------------------ policy
    def act(self, obs: dict) -> np.ndarray:
        self._count_failed_attempts()
        if self.way_is_open():
            action = self.drive_to(self.env.task.goal_xy)
        else:
            action = self.clear_red_box()
        self._pushed = bool(action[0] <= 0.0)
        return action

    def _count_failed_attempts(self) -> None:
        task = self.env.task
        state = np.concatenate([self.env.robot.base_pose()[:2], task.red.position()[:2]])
        stuck = self._last_state is not None and np.allclose(state, self._last_state, atol=0.03)
        self._attempt = self._attempt + 1 if stuck else 0
        red_moved = self._last_state is not None and np.linalg.norm(state[2:] - self._last_state[2:]) > 0.03
        self._arm_failures = 0 if red_moved else self._arm_failures + int(self._pushed)
        self._last_state = state

    def way_is_open(self) -> bool:
        """Whether the shortest path around the boxes reaches the robot (finite distance)."""
        return bool(np.isfinite(self.field_to(self.env.task.goal_xy).distance(self.env.robot.base_pose()[:2])))

    # --------------------------------------------------------------------- pushing
    def clear_red_box(self) -> np.ndarray:
        task = self.env.task
        xy, yaw = task.red.pose2d()
        face, push_dir = box_face(xy, yaw, task.half, -task.door.normal)
        stand = self.push_pose(face, push_dir, rank=(self._arm_failures // ARM_TRIES_PER_POSE) % POSE_CHOICES)
        if stand is None:
            return self.drive_to(task.door.point_in_front(task.door.regions[0], 0.6))
        stand_xy, stand_yaw = stand
        x, y, heading = self.env.robot.base_pose()
        far = np.hypot(*(stand_xy - (x, y))) > POSE_TOLERANCE[0] or abs(wrap(stand_yaw - heading)) > POSE_TOLERANCE[1]
        if far and (self._attempt < 2 or np.hypot(*(stand_xy - (x, y))) > 0.5):
            return self.drive_to(stand_xy, stand_yaw)
        point = np.array([*face, PUSH_HEIGHTS[self._arm_failures % len(PUSH_HEIGHTS)]])
        action = arm_action(self.env, point, np.array([*push_dir * PUSH_LENGTH, 0.0]))
        if action is None:  # face out of view: turn toward it
            return base_action(self.env, (x, y), float(np.arctan2(face[1] - y, face[0] - x)))
        return action

    def push_pose(self, face: np.ndarray, push_dir: np.ndarray, rank: int = 0) -> tuple[np.ndarray, float] | None:
        """Base pose facing the face from behind it, clear of walls and both boxes. Candidates
        are ranked by closeness to the preferred stand-off and to the doorway's centre line
        (the arm passes the doorway there); ``rank`` picks a later one, >= 0.15 m from the
        better ones, to vary the arm's problem after failures. None if there is none."""
        task, robot = self.env.task, self.env.robot
        side = np.array([-push_dir[1], push_dir[0]])
        grid = np.array([[face - d * push_dir + s * side for s in SIDE_OFFSETS] for d in STAND_OFF])
        clearance_needed = robot.spec.base_radius + BASE_MARGIN
        ok = self._static_clearance(grid) >= clearance_needed
        for xy, yaw, half in task.obstacle_footprints():
            ok &= distance_to_box(grid, xy, yaw, half[0]) >= clearance_needed
        off_centre = np.abs((grid - np.asarray(task.door.center)) @ task.door.along)
        cost = np.abs(STAND_OFF - PREFERRED_STAND_OFF)[:, None] + off_centre
        order = [k for k in np.argsort(np.where(ok, cost, np.inf), axis=None) if ok.flat[k]]
        chosen: list[np.ndarray] = []
        for k in order:
            xy = grid.reshape(-1, 2)[k]
            if all(np.linalg.norm(xy - c) >= 0.15 for c in chosen):
                chosen.append(xy)
            if len(chosen) > rank:
                break
        if not chosen:
            return None
        stand_xy = chosen[-1]
        return stand_xy, float(np.arctan2(face[1] - stand_xy[1], face[0] - stand_xy[0]))

    def _static_clearance(self, points: np.ndarray) -> np.ndarray:
        trav = self.env.task.ctx.scene.trav_map
        cells = trav.world_to_cell(points)
        inside = trav.in_grid(cells)
        clearance = trav.clearance_grid()
        rows, cols = np.where(inside, cells[..., 0], 0), np.where(inside, cells[..., 1], 0)
        return np.where(inside, clearance[rows, cols], 0.0)

    # ------------------------------------------------------------------- driving
    def drive_to(self, target_xy: np.ndarray, final_yaw: float | None = None) -> np.ndarray:
        """Hop along the shortest path to ``target_xy`` on the floor plan with the boxes; turn
        toward the hop first when it lies outside the LiDAR's view (unseen cells block plans)."""
        x, y, heading = self.env.robot.base_pose()
        if self._attempt >= ESCAPE_AFTER:
            return self.escape()
        if np.hypot(target_xy[0] - x, target_xy[1] - y) <= 1.8 and self._attempt == 0:
            hop, yaw = np.asarray(target_xy), final_yaw
        else:
            hop, yaw = self.next_hop(target_xy, final_yaw)
        bearing = wrap(float(np.arctan2(hop[1] - y, hop[0] - x)) - heading)
        if abs(bearing) > TURN_FIRST and np.hypot(hop[0] - x, hop[1] - y) > 0.3:
            return base_action(self.env, (x, y), heading + bearing)
        return base_action(self.env, hop, yaw)

    def next_hop(self, target_xy: np.ndarray, final_yaw: float | None) -> tuple[np.ndarray, float | None]:
        n = LOOKAHEADS[min(self._attempt, len(LOOKAHEADS) - 1)]
        waypoints = self.field_to(target_xy).waypoints(self.env.robot.base_pose()[:2], 12, 0.2)
        onward = waypoints[min(n + 1, len(waypoints) - 1)] - waypoints[n - 1]
        yaw = float(np.arctan2(onward[1], onward[0])) if np.linalg.norm(onward) > 1e-6 else final_yaw
        return waypoints[n - 1], yaw

    def escape(self) -> np.ndarray:
        """After repeated failures: a random nearby pose well clear of walls and boxes."""
        task, robot = self.env.task, self.env.robot
        rng = np.random.default_rng(self._attempt)
        x, y, heading = robot.base_pose()
        angles = rng.uniform(-np.pi, np.pi, 64)
        radii = rng.uniform(0.3, 1.2, 64)
        points = np.stack([x + radii * np.cos(angles), y + radii * np.sin(angles)], axis=-1)
        clear = self._static_clearance(points)
        for xy, yaw, half in task.obstacle_footprints():
            clear = np.minimum(clear, distance_to_box(points, xy, yaw, half[0]))
        best = points[int(np.argmax(clear))]
        return base_action(self.env, best, float(rng.uniform(-np.pi, np.pi)))

    def field_to(self, target_xy: np.ndarray) -> GeodesicField:
        """Geodesic field to ``target_xy`` on the static plan plus the boxes (cached until
        the target or a box moves)."""
        task = self.env.task
        key = np.round(np.concatenate([np.asarray(target_xy), task.red.position()[:2]]), 2).tobytes()
        if key != self._field_key:
            trav = task.ctx.scene.trav_map
            free = trav.free.copy()
            points = trav.cell_to_world(np.stack(np.indices(trav.shape), axis=-1))
            for xy, yaw, half in task.obstacle_footprints():
                free &= distance_to_box(points, xy, yaw, half[0]) > 0.5 * trav.resolution
            boxes_map = TraversabilityMap(free, trav.origin, trav.resolution)
            self._field = GeodesicField(boxes_map, target_xy, self.env.robot.spec.base_radius + PATH_MARGIN)
            self._field_key = key
        return self._field
