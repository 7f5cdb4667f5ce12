"""InteractiveObstaclesNav: push the light (red) obstacle out of the way to reach the goal.

Task Description:
    The robot starts in the office corridor and must bring its base centre within 0.5 m of
    a goal in the goal room (``scene.goal_region``), whose only doorway
    (``scene.goal_doorway``) is blocked by two 0.7 x 0.7 x 1.2 m boxes standing side by side
    just inside the room. The red box weighs 1 kg and slides when the arm pushes it; the
    green one weighs 1e4 kg and does not move. Only their colour tells them apart. The
    shortest path in ``task_obs`` is computed on the static floor plan, so it runs straight
    through the boxes. Touching a box with anything but the gripper ends a joint-control
    episode (collision); base subgoals stop before touching one.

Randomizations:
    Every episode: the barrier (gap between the wall face and the boxes 0.40-0.45 m, too
    narrow for the 0.558 m wide base; offset of the pair along the wall; which side the red
    box is on, 50/50), drawn from a set of layouts checked at load time on the
    traversability map: with both boxes in place the goal room cannot be entered, and after
    pushing the red box at most 0.5 m (two 0.25 m pushes) further into the room it can
    (with 3 cm to spare around the base). Start pose in the corridor and goal in the goal
    room with a geodesic distance of 1.5-10 m on the static plan, the goal at least 0.6 m
    from where the boxes stand or are pushed to.

Success Conditions:
    xy distance from the base centre to the goal below 0.5 m (d_th). The episode ends on
    success.

Reward:
    geodesic: (previous - current) geodesic distance to the goal on the static floor plan
        (boxes ignored), weight 1.
    displacement: increase of the summed xy displacement of the boxes from their start
        positions (metres, each beyond a 1 cm dead band that hides resting contact creep),
        weight 1 (a potential, so pushing back and forth earns nothing).
    success: +10 once, when a decision (a subgoal, or a joint step) ends with the success
        condition holding (the episode ends then); passing through the goal mid-subgoal earns nothing.

Metrics:
    success (SR), spl, path_length, shortest_path_length, goal_distance,
    red_displacement and green_displacement (metres the boxes moved in the episode).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy import ndimage

from relmogen.scenes.geometry import Doorway, Rect
from relmogen.scenes.navigation import StartGoal
from relmogen.scenes.objects.obstacles import HEAVY_OBSTACLE, LIGHT_OBSTACLE, BoxObstacle, footprint_mask
from relmogen.tasks.base import register_task
from relmogen.tasks.navigation import NavigationTask
from relmogen.tasks.terms import PotentialReward

PUSH_LENGTH = 0.25
CLEARING_PUSHES = 2  # a valid layout opens after at most this many forward pushes of the red box
WALL_GAPS = (0.40, 0.425, 0.45)  # wall face -> near faces of the boxes (base diameter 0.558 m)
PAIR_SHIFTS = tuple(np.round(np.arange(-0.45, 0.451, 0.05), 3))  # pair centre along the wall
PAIR_SPACING = 0.02  # between the two boxes, so they never start in contact
BLOCKED_SLACK = -0.03  # "blocked" must hold for a base 3 cm thinner than Fetch's
OPEN_SLACK = 0.03  # "open" must hold for a base 3 cm fatter
GOAL_CLEARANCE = 0.6  # goal distance from the boxes' start and pushed-to area
# Boxes at rest creep ~1e-5 m per step on their floor contacts (differently right after a
# re-pose), so the reward counts displacement beyond this (a push moves a box 0.2-0.3 m).
DISPLACEMENT_DEADBAND = 0.01


@dataclass(frozen=True)
class Barrier:
    """Two boxes side by side parallel to the doorway's wall, inside the goal room."""

    wall_gap: float  # metres from the wall face to the boxes' near faces
    shift: float  # metres along ``doorway.along`` from the doorway centre to the pair centre
    red_side: int  # +1: red on the ``doorway.along`` side of the pair, -1: the other side

    def poses(self, door: Doorway, half: float) -> tuple[np.ndarray, np.ndarray]:
        """World xy of the red and the green box centres."""
        depth = 0.5 * door.wall_thickness + self.wall_gap + half
        centre = np.asarray(door.center) + depth * door.normal + self.shift * door.along
        offset = (half + 0.5 * PAIR_SPACING) * door.along
        return centre + self.red_side * offset, centre - self.red_side * offset


def passable_grid(scene, boxes, radius: float, window: Rect | None = None):
    """Cells of ``window`` (default: the whole map) where a disc of ``radius`` clears the static
    plan and the box footprints ``boxes`` [(xy, yaw, half_xy)]; returns (mask, world xy)."""
    m = scene.trav_map
    window = window or m.bounds
    (r0, c0), (r1, c1) = m.world_to_cell(np.array([[window.xmin, window.ymin], [window.xmax, window.ymax]]))
    r0, c0 = max(r0, 0), max(c0, 0)
    r1, c1 = min(r1, m.shape[0]), min(c1, m.shape[1])
    rows, cols = np.mgrid[r0:r1, c0:c1]
    points = m.cell_to_world(np.stack([rows, cols], axis=-1))
    free = m.free[r0:r1, c0:c1].copy()
    for xy, yaw, half_xy in boxes:
        # grown by half a cell: distances below are measured between cell centres
        free &= ~footprint_mask(points, xy, yaw, half_xy, 0.5 * m.resolution)
    return ndimage.distance_transform_edt(free) * m.resolution > radius, points


def connected(passable: np.ndarray, points: np.ndarray, start_xy, targets: np.ndarray) -> bool:
    """Whether the passable cell nearest ``start_xy`` shares a component with any ``targets`` cell."""
    labels, _ = ndimage.label(passable, structure=np.ones((3, 3)))
    distance = np.linalg.norm(points - np.asarray(start_xy)[:2], axis=-1)
    distance[~passable] = np.inf
    nearest = np.unravel_index(np.argmin(distance), distance.shape)
    if distance[nearest] > 0.3:
        return False
    return bool(np.any(labels[targets & passable] == labels[nearest]))


@register_task
class InteractiveObstaclesNav(NavigationTask):
    name = "InteractiveObstaclesNav"
    min_geodesic = 1.5
    max_geodesic = 10.0
    displacement_weight: ClassVar[float] = 1.0
    _layout_cache: ClassVar[dict[tuple, list[Barrier]]] = {}

    def __init__(self, ctx):
        super().__init__(ctx)
        self.red_start = np.zeros(2)
        self.green_start = np.zeros(2)
        self.barrier: Barrier | None = None
        self.reward_terms.insert(1, PotentialReward("displacement", lambda: -self.rewarded_displacement(),
                                                    self.displacement_weight))

    # ---------------------------------------------------------------------------- setup
    def load(self) -> None:
        super().load()
        scene = self.ctx.scene
        if scene.goal_doorway is None:
            raise ValueError(f"scene {scene.name} has no doorway between its start and goal regions")
        self.door: Doorway = scene.goal_doorway
        self.red = BoxObstacle(self.ctx.world.client, LIGHT_OBSTACLE)
        self.green = BoxObstacle(self.ctx.world.client, HEAVY_OBSTACLE)
        self.half = float(self.red.half_extents[0])
        self.layouts = self._valid_layouts()

    def _valid_layouts(self) -> dict[int, list[Barrier]]:
        """Layouts per red side; checked once per scene, robot size and process (about a second)."""
        scene = self.ctx.scene
        key = (scene.name, scene.seed, self.ctx.robot.spec.base_radius)  # validity depends on the base's size
        if key not in self._layout_cache:
            candidates = [Barrier(g, s, side) for g, s, side in itertools.product(WALL_GAPS, PAIR_SHIFTS, (-1, 1))]
            self._layout_cache[key] = [b for b in candidates if self.layout_is_valid(b)]
        layouts = {side: [b for b in self._layout_cache[key] if b.red_side == side] for side in (-1, 1)}
        if not layouts[-1] or not layouts[1]:
            raise RuntimeError(f"no valid obstacle layout at the goal doorway of {scene.name}")
        return layouts

    def layout_is_valid(self, barrier: Barrier) -> bool:
        """Both boxes on free floor; blocked with both; open once the red box is pushed
        ``CLEARING_PUSHES`` times."""
        red, green = barrier.poses(self.door, self.half)
        radius = self.ctx.robot.spec.base_radius
        if not (self.on_free_floor(red) and self.on_free_floor(green)):
            return False
        if self.room_reachable([red, green], radius + BLOCKED_SLACK):
            return False
        pushed = red + CLEARING_PUSHES * PUSH_LENGTH * self.door.normal
        return self.room_reachable([pushed, green], radius + OPEN_SLACK)

    def on_free_floor(self, xy: np.ndarray, margin: float = 0.03) -> bool:
        """Whether a box at ``xy`` (door-aligned) clears walls and furniture by ``margin``."""
        trav = self.ctx.scene.trav_map
        offsets = np.arange(-self.half - margin, self.half + margin + 1e-9, 0.5 * trav.resolution)
        points = np.stack(np.meshgrid(offsets, offsets), axis=-1).reshape(-1, 2) + np.asarray(xy)
        return bool(np.all(trav.is_free(points)))

    def room_reachable(self, box_xys, radius: float) -> bool:
        """Whether a base of ``radius`` can drive from the corridor in front of the goal doorway
        to the goal room beyond the obstacles (the room has no other doorway)."""
        door, half = self.door, self.half
        window = Rect.around(door.center, (7.0, 7.0))
        boxes = [(xy, door.yaw, (half, half)) for xy in box_xys]
        passable, points = passable_grid(self.ctx.scene, boxes, radius, window)
        depth = (points - np.asarray(door.center)) @ door.normal
        beyond = depth > 0.5 * door.wall_thickness + max(WALL_GAPS) + 2 * half + CLEARING_PUSHES * PUSH_LENGTH + 0.6
        room = self.ctx.scene.regions[self.ctx.scene.goal_region]
        in_room = ((points[..., 0] >= room.xmin) & (points[..., 0] <= room.xmax)
                   & (points[..., 1] >= room.ymin) & (points[..., 1] <= room.ymax))
        return connected(passable, points, door.point_in_front(door.regions[0], 0.7), beyond & in_room)

    # -------------------------------------------------------------------------- episode
    def object_bodies(self) -> list[int]:
        return [self.red.body_id, self.green.body_id]

    def reset(self, rng: np.random.Generator) -> None:
        side = -1 if rng.random() < 0.5 else 1
        options = self.layouts[side]
        self.barrier = options[rng.integers(len(options))]
        self.red_start, self.green_start = self.barrier.poses(self.door, self.half)
        self.red.set_pose(self.red_start, self.door.yaw)
        self.green.set_pose(self.green_start, self.door.yaw)
        sample = self._sample_start_goal(rng)
        self.set_goal(sample.goal_xy, sample.field)
        self.ctx.robot.reset((*sample.start_xy, sample.start_yaw), head_tilt=self.head_tilt_angle())
        self.start_episode()

    def _sample_start_goal(self, rng: np.random.Generator) -> StartGoal:
        """Goal first (rejected near the boxes, cheap), one field solve, then the start."""
        scene, radius = self.ctx.scene, self.ctx.robot.spec.base_radius
        for _ in range(20):
            goal = self.sample_free_point(rng, scene.goal_region)
            if not self.goal_clear_of_obstacles(goal):
                continue
            field = scene.geodesic_field(goal, radius)
            for _ in range(50):
                start = self.sample_free_point(rng, scene.start_region)
                distance = field.distance(start)
                if self.min_geodesic <= distance <= self.max_geodesic:
                    return StartGoal(start, float(rng.uniform(-np.pi, np.pi)), goal, distance, field)
        raise RuntimeError(f"no start/goal pair in {scene.start_region} / {scene.goal_region}")

    def obstacle_zone(self) -> Rect:
        """Floor the boxes cover at the start or after the clearing pushes, as a door-frame
        rectangle: (depth from the doorway centre along the normal, offset along the wall)."""
        near = 0.5 * self.door.wall_thickness + self.barrier.wall_gap
        far = near + 2 * self.half + CLEARING_PUSHES * PUSH_LENGTH + PUSH_LENGTH
        width = 2 * self.half + 0.5 * PAIR_SPACING
        return Rect(near, self.barrier.shift - width, far, self.barrier.shift + width)

    def goal_clear_of_obstacles(self, goal_xy) -> bool:
        local = np.asarray(goal_xy) - np.asarray(self.door.center)
        depth, along = float(local @ self.door.normal), float(local @ self.door.along)
        zone = self.obstacle_zone().shrunk(-GOAL_CLEARANCE)
        return not zone.contains((depth, along))

    # ------------------------------------------------------------------------ queries
    def displacements(self) -> tuple[float, float]:
        red = float(np.linalg.norm(self.red.position()[:2] - self.red_start))
        green = float(np.linalg.norm(self.green.position()[:2] - self.green_start))
        return red, green

    def rewarded_displacement(self) -> float:
        return float(sum(max(d - DISPLACEMENT_DEADBAND, 0.0) for d in self.displacements()))

    def obstacle_footprints(self) -> list[tuple[np.ndarray, float, tuple[float, float]]]:
        """Current (xy, yaw, half extents) of both boxes (for planners and oracles)."""
        return [(*box.pose2d(), (self.half, self.half)) for box in (self.red, self.green)]

    def metrics(self) -> dict[str, float]:
        red, green = self.displacements()
        return {**super().metrics(), "red_displacement": red, "green_displacement": green}
