"""ArrangeKitchenMM: close every open drawer and cabinet door in the kitchen.

Task Description:
    Four kitchen cabinet sets stand along the three free walls of the kitchen
    (``scene.kitchen_walls``). Each set has a drawer on top (prismatic) and a door below
    (revolute, hinge on the set's left side seen from the room), all opened at random.
    The robot must push as many of the eight items shut as it can within the time budget
    (25 subgoals, 750 joint-velocity steps). As in the paper there is NO goal information:
    ``task_obs`` is the 33-D proprioception only; the open items must be found in the images.
    The head uses the spec's ``tabletop`` tilt (45 deg down): every front (0.1-0.82 m high)
    is in view from the 0.6-1.0 m a robot stands from it, and farther away too.

Randomizations:
    Cabinets: every wall gets at least one set, the fourth goes to a random wall; positions
    along a wall are uniform, 0.15 m apart at least. Layouts are redrawn until every set has
    standing room for the robot in front of its hinge side (a 0.35 m disc 0.85 m out from the
    front and 0.55 m to the hinge side of its centre, clear of the walls and of every other
    set with 0.55 m in front of it for its opened parts): every item can be closed.
    Openings: drawers uniform in [0.15, 0.30] m (one 0.25 m push plus the gripper's reach
    past the front closes any of them), doors uniform in [30, 90] deg: all start beyond the
    loose tolerance, so ``open_at_start`` is always 8.
    Robot: a uniform free point in the kitchen, uniform yaw, at least 0.1 m from every
    cabinet including its opened drawer and door.

Success Conditions:
    All eight items closed within the loose tolerance (drawer <= 0.10 m, door <= 10 deg).
    The episode ends on success.

Reward:
    closing: 10 x the decrease of the summed openings, a potential. Doors count in radians,
    drawers in metres times (10 deg / 0.10 m) = 1.745 rad/m, so an item at the loose
    tolerance weighs the same whether drawer or door. Closing a 0.25 m drawer earns 4.4,
    closing a 60 deg door 10.5. Nothing for approaching, no success bonus.

Metrics:
    success, closed_5 (items within 5 cm / 5 deg), closed_10 (within 10 cm / 10 deg),
    items (8), open_at_start, closed_10_fraction = closed_10 / open_at_start.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as p

from relmogen.scenes.geometry import WallSegment
from relmogen.scenes.objects.cabinet import DEPTH, WIDTH, Cabinet
from relmogen.tasks.base import Task, register_task
from relmogen.tasks.terms import PotentialReward

DRAWER_M_TO_RAD = math.radians(10.0) / 0.10  # equal weight at the loose tolerance
STANDING_SPOT = (0.85, -0.55)  # set frame: out from the front, along it (hinge side negative)
STANDING_RADIUS = 0.35
OPENED_REACH = 0.55  # how far an opened drawer or door can stand out of the front
TIGHT = (0.05, math.radians(5.0))  # drawer metres, door radians
LOOSE = (0.10, math.radians(10.0))


@register_task
class ArrangeKitchenMM(Task):
    name = "ArrangeKitchenMM"
    scene_kind = "house"
    head_tilt = "tabletop"
    subgoal_steps = 25
    task_obs_dim = 33  # proprioception only: no goal information, as in the paper
    num_cabinets = 4
    drawer_opening_range = (0.15, 0.30)
    door_opening_range = (math.radians(30.0), math.radians(90.0))
    wall_end_margin = 0.05
    min_gap = 0.15
    robot_clearance = 0.1
    closing_weight = 10.0

    def __init__(self, ctx):
        super().__init__(ctx)
        self.cabinets: list[Cabinet] = []
        self._open_at_start = 0
        self.reward_terms = [PotentialReward("closing", self.summed_openings, self.closing_weight)]

    def load(self) -> None:
        self.cabinets = [Cabinet(self.ctx.world.client) for _ in range(self.num_cabinets)]
        robot = self.ctx.robot
        fingers = [link for link in robot.gripper_link_indices if link != robot.end_effector_link_index]
        for cabinet in self.cabinets:
            cabinet.ignore_collisions_with(robot.robot_id, fingers)

    # ------------------------------------------------------------------ episode set-up
    def object_bodies(self) -> list[int]:
        return [cabinet.body for cabinet in self.cabinets]

    def reset(self, rng: np.random.Generator) -> None:
        self._place_cabinets(rng)
        for cabinet in self.cabinets:
            cabinet.set_openings(rng.uniform(*self.drawer_opening_range), rng.uniform(*self.door_opening_range))
        self._place_robot(rng)
        self._open_at_start = len(self.items()) - self.count_closed(LOOSE)

    def _place_cabinets(self, rng: np.random.Generator) -> None:
        for _ in range(500):
            poses = self._sample_layout(rng)
            if self._has_standing_room(poses):
                break
        for cabinet, (front_xy, yaw) in zip(self.cabinets, poses):
            cabinet.place(front_xy, yaw)

    def _sample_layout(self, rng: np.random.Generator) -> list[tuple[np.ndarray, float]]:
        """Front-centre xy and yaw of every set: each wall gets one, the last a random wall."""
        walls = self.ctx.scene.kitchen_walls
        choice = list(rng.permutation(len(walls)))
        choice += list(rng.integers(len(walls), size=self.num_cabinets - len(choice)))
        poses = []
        for index, wall in enumerate(walls):
            inward = np.array([math.cos(wall.normal_yaw), math.sin(wall.normal_yaw)])
            for s in self._positions_along(rng, wall, choice.count(index)):
                poses.append((wall.point_at(s) + (DEPTH + 0.005) * inward, wall.normal_yaw))
        return poses

    def _has_standing_room(self, poses: list[tuple[np.ndarray, float]]) -> bool:
        return all(self.spot_is_clear(_set_to_world(front, yaw, STANDING_SPOT), poses) for front, yaw in poses)

    def spot_is_clear(self, xy, poses: list[tuple[np.ndarray, float]] | None = None,
                      radius: float = STANDING_RADIUS) -> bool:
        """Whether a disc at ``xy`` lies in the kitchen, clear of every set and of the space
        in front of it that its opened parts may take (the current sets unless ``poses``)."""
        if not self.ctx.scene.regions["kitchen"].contains(xy, margin=radius):
            return False
        poses = poses if poses is not None else [(c.front_xy, c.yaw) for c in self.cabinets]
        for front, yaw in poses:
            local = _world_to_set(front, yaw, xy)
            nearest = np.clip(local, (-DEPTH, -0.5 * WIDTH - 0.03), (OPENED_REACH, 0.5 * WIDTH))
            if np.linalg.norm(local - nearest) < radius:
                return False
        return True

    def _positions_along(self, rng: np.random.Generator, wall: WallSegment, count: int) -> list[float]:
        """``count`` set centres along ``wall``, apart and away from its ends."""
        low, high = self.wall_end_margin + 0.5 * WIDTH, wall.length - self.wall_end_margin - 0.5 * WIDTH
        for _ in range(200):
            s = np.sort(rng.uniform(low, high, count))
            if count < 2 or np.diff(s).min() >= WIDTH + self.min_gap:
                return list(s)
        return list(np.linspace(low, high, count))  # evenly spread: always fits on these walls

    def standing_pose(self, cabinet: Cabinet) -> np.ndarray:
        """The pose (x, y, yaw) in front of the set's hinge side kept free by the layout,
        facing the set."""
        xy = cabinet.to_world(*STANDING_SPOT)
        look = cabinet.to_world(0.15, -0.1) - xy
        return np.array([xy[0], xy[1], math.atan2(look[1], look[0])])

    def _place_robot(self, rng: np.random.Generator) -> None:
        robot, client = self.ctx.robot, self.ctx.world.client
        for _ in range(200):
            xy = self.sample_free_point(rng, "kitchen")
            robot.reset((xy[0], xy[1], rng.uniform(-math.pi, math.pi)), head_tilt=self.head_tilt_angle())
            if not any(p.getClosestPoints(robot.robot_id, c.body, self.robot_clearance, physicsClientId=client)
                       for c in self.cabinets):
                return
        raise RuntimeError("no free robot start in the kitchen next to the cabinets")

    # ------------------------------------------------------------------ state
    def items(self) -> list[tuple[Cabinet, str]]:
        return [(c, kind) for c in self.cabinets for kind in ("drawer", "door")]

    @staticmethod
    def opening(cabinet: Cabinet, kind: str) -> float:
        """Drawer metres or door radians, never negative."""
        return max(0.0, cabinet.drawer_opening() if kind == "drawer" else cabinet.door_angle())

    def is_closed(self, cabinet: Cabinet, kind: str, tolerance: tuple[float, float] = LOOSE) -> bool:
        return self.opening(cabinet, kind) <= tolerance[0 if kind == "drawer" else 1]

    def count_closed(self, tolerance: tuple[float, float]) -> int:
        return sum(self.is_closed(c, kind, tolerance) for c, kind in self.items())

    def summed_openings(self) -> float:
        return sum(self.opening(c, kind) * (DRAWER_M_TO_RAD if kind == "drawer" else 1.0) for c, kind in self.items())

    # ------------------------------------------------------------------ task interface
    def task_obs(self) -> np.ndarray:
        return self.proprioception()

    def is_success(self) -> bool:
        return self.count_closed(LOOSE) == len(self.items())

    def metrics(self) -> dict[str, float]:
        closed_10 = self.count_closed(LOOSE)
        return {
            "success": float(closed_10 == len(self.items())),
            "closed_5": float(self.count_closed(TIGHT)),
            "closed_10": float(closed_10),
            "items": float(len(self.items())),
            "open_at_start": float(self._open_at_start),
            "closed_10_fraction": closed_10 / self._open_at_start if self._open_at_start else 1.0,
        }


def _set_to_world(front: np.ndarray, yaw: float, local) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return front + np.array([c * local[0] - s * local[1], s * local[0] + c * local[1]])


def _world_to_set(front: np.ndarray, yaw: float, xy) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    d = np.asarray(xy) - front
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])
