"""ArrangeKitchenMM oracle: visit the cabinet sets in the shortest order and push shut
first the door, then the drawer of each.

Privileged state: which items are open and the cabinets' poses. It acts through subgoal-r
only. For each set the robot stands at the task's standing spot in front of the set's hinge
side (from where the door's outer face is in view at any opening), facing the set; from afar
it first drives to an approach point clear of every set, because the spot is often in the
LiDAR shadow of an open door and the base planner treats unseen space as occupied.
Door: a push from the outer face 0.3 m from the hinge towards the door's face line at the
angle one 0.25 m push can reach (1.5 deg short of closed when in reach: never press a front
into its stop); wide-open doors take a second push. Drawer: a push on the front along the
closing axis, ending 1 cm short of closed. An item is given up after 4 arm subgoals that did
not close it noticeably (failed arm plans, slips).
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from relmogen.agents.oracles.base import (
    Oracle,
    arm_action,
    base_action,
    register_oracle,
    wrap,
)
from relmogen.scenes.objects.cabinet import DOOR_Z, DRAWER_Z, FRONT_THICKNESS, Cabinet
from relmogen.tasks.arrange_kitchen_mm import ArrangeKitchenMM

# Approach points: on rings around the standing spot (often in the LiDAR shadow of an open
# door or another set when seen from afar), clear of every set.
APPROACH_RADII = (0.5, 0.7, 0.9, 1.2)
APPROACH_DIRECTIONS = 16
ARRIVED_XY, ARRIVED_YAW = 0.12, 0.25
DOOR_RADIUS = 0.3  # push contact from the hinge axis, along the door
DOOR_PUSH_Z = 0.5 * (DOOR_Z[0] + DOOR_Z[1]) + 0.08
DRAWER_PUSH_Z = 0.5 * (DRAWER_Z[0] + DRAWER_Z[1])
DRAWER_PUSH_SIDE = -0.13  # along the front from its centre: clear of the handle
PUSH = 0.25
CLOSED_DRAWER, CLOSED_DOOR = 0.04, math.radians(4.0)  # aim below the tight tolerance
FUTILE_ATTEMPTS = 4  # arm subgoals on one item without progress (failed plans, slips) before giving up
PROGRESS = {"door": math.radians(3.0), "drawer": 0.02}
TURN_IN_PLACE = np.array([1.0, 0.0, -1.0, 0.5, 0, 0, 0, 0], dtype=np.float32)


@register_oracle
class ArrangeKitchenOracle(Oracle):
    task_name = ArrangeKitchenMM.name

    def reset(self) -> None:
        self.futile: dict[tuple[int, str], int] = {}
        self._last_push: tuple[tuple[int, str], float] | None = None
        self.route = self._shortest_route()
        self._last_pose = None
        self._stuck = 0

    # ------------------------------------------------------------------ planning
    def _shortest_route(self) -> list[Cabinet]:
        """The order of the cabinet sets minimising the straight-line driving distance."""
        start = self.env.robot.base_pose()[:2]
        cabinets = self.env.task.cabinets

        def length(order) -> float:
            points = [start] + [self.env.task.standing_pose(c)[:2] for c in order]
            return sum(float(np.linalg.norm(b - a)) for a, b in zip(points, points[1:]))

        return list(min(itertools.permutations(cabinets), key=length))

    def _pending(self, cabinet: Cabinet) -> str | None:
        """The next item of ``cabinet`` to push: the door first (it can block the arm's way)."""
        index = self.env.task.cabinets.index(cabinet)
        for kind, limit in (("door", CLOSED_DOOR), ("drawer", CLOSED_DRAWER)):
            opening = ArrangeKitchenMM.opening(cabinet, kind)
            if opening > limit and self.futile.get((index, kind), 0) < FUTILE_ATTEMPTS:
                return kind
        return None

    # ------------------------------------------------------------------ acting
    def _book_last_push(self) -> None:
        """Count the previous arm subgoal as futile when its item did not close noticeably."""
        if self._last_push is None:
            return
        (index, kind), before = self._last_push
        now = ArrangeKitchenMM.opening(self.env.task.cabinets[index], kind)
        if before - now < PROGRESS[kind]:
            self.futile[(index, kind)] = self.futile.get((index, kind), 0) + 1
        self._last_push = None

    def act(self, obs: dict) -> np.ndarray:
        self._book_last_push()
        cabinet, kind = next(((c, k) for c in self.route if (k := self._pending(c))), (None, None))
        if cabinet is None:
            return TURN_IN_PLACE
        target = self.env.task.standing_pose(cabinet)
        pose = self.env.robot.base_pose()
        if not self._arrived(pose, target):
            return self._drive(pose, target, cabinet)
        point, push = door_push(cabinet) if kind == "door" else drawer_push(cabinet)
        action = arm_action(self.env, point, push)
        if action is None:  # out of view: face the set squarely
            return base_action(self.env, target[:2], target[2])
        index = self.env.task.cabinets.index(cabinet)
        self._last_push = ((index, kind), ArrangeKitchenMM.opening(cabinet, kind))
        return action

    @staticmethod
    def _arrived(pose: np.ndarray, target: np.ndarray) -> bool:
        return (np.linalg.norm(pose[:2] - target[:2]) <= ARRIVED_XY
                and abs(wrap(pose[2] - target[2])) <= ARRIVED_YAW)

    def _drive(self, pose: np.ndarray, target: np.ndarray, cabinet: Cabinet) -> np.ndarray:
        """Straight to the standing pose when near; from afar (or after failed plans) via an
        approach point from where the standing spot is seen."""
        stuck = self._last_pose is not None and np.allclose(pose, self._last_pose, atol=1e-3)
        self._stuck = self._stuck + 1 if stuck else 0
        self._last_pose = pose
        goal = target[:2]
        approach = self._approach_point(pose, target, randomly=self._stuck >= 2)
        far = np.linalg.norm(pose[:2] - goal) > 1.0 and np.linalg.norm(pose[:2] - approach) > ARRIVED_XY + 0.1 \
            if approach is not None else False
        if approach is not None and (far or self._stuck >= 2):
            goal = approach
        elif self._stuck:  # a failed plan: try a nearby goal instead
            goal = goal + self.env.np_random.uniform(-0.15, 0.15, 2) * min(self._stuck, 3)
        return base_action(self.env, goal, target[2])


    def _approach_point(self, pose: np.ndarray, target: np.ndarray, randomly: bool) -> np.ndarray | None:
        """The clear ring point nearest the robot (a random one after repeated failures)."""
        angles = np.linspace(0, 2 * np.pi, APPROACH_DIRECTIONS, endpoint=False)
        ring = [target[:2] + r * np.array([np.cos(a), np.sin(a)]) for r in APPROACH_RADII for a in angles]
        clear = [xy for xy in ring if self.env.task.spot_is_clear(xy, radius=0.3)]
        if not clear:
            return None
        if randomly:
            return clear[self.env.np_random.integers(len(clear))]
        return min(clear, key=lambda xy: float(np.linalg.norm(xy - pose[:2])))


def door_push(cabinet: Cabinet) -> tuple[np.ndarray, np.ndarray]:
    """World contact point on the door's outer face and the push vector (see module doc)."""
    angle = cabinet.door_angle()
    start = cabinet.door_face_point(DOOR_RADIUS, angle)
    reachable = math.asin(min(1.0, PUSH / DOOR_RADIUS))
    final = max(angle - reachable, math.radians(1.5))  # never press the door into its stop
    # The nearest point to `start` on the door's face line at the final angle.
    hinge = cabinet.hinge_xy() + FRONT_THICKNESS * cabinet.door_outer_normal(final)
    direction = cabinet.door_direction(final)
    end = hinge + max(0.05, float(np.dot(start - hinge, direction))) * direction
    return np.array([*start, DOOR_PUSH_Z]), np.array([*(end - start), 0.0])


def drawer_push(cabinet: Cabinet) -> tuple[np.ndarray, np.ndarray]:
    opening = cabinet.drawer_opening()
    start = cabinet.to_world(opening + FRONT_THICKNESS, DRAWER_PUSH_SIDE)
    push = -cabinet.normal * min(PUSH, opening - 0.01)  # stop at the closed front, never press it
    return np.array([*start, DRAWER_PUSH_Z]), np.array([*push, 0.0])
