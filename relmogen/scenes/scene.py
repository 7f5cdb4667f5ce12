"""`Scene`: a layout spawned into one PyBullet client, plus its navigation helpers.

Boxes are merged into compound bodies (PyBullet allows at most 16 shapes per compound),
one group per element class and colour, so a scene is a few dozen static bodies at most.
Build a scene once per environment; episode resets only resample poses and goals.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Callable

import numpy as np
import pybullet as p

from relmogen.scenes.geometry import Box, Doorway, Layout, Rect, Table, WallSegment
from relmogen.scenes.house import house_a, house_b
from relmogen.scenes.navigation import (FREE_POINT_MARGIN, ROBOT_RADIUS, GeodesicField, StartGoal, TraversabilityMap,
                                        sample_free_point, sample_start_goal)
from relmogen.scenes.office import office_a, office_b
from relmogen.simulation.shapes import box_collision_shape, record_body

MAX_SHAPES_PER_COMPOUND = 16  # PyBullet silently drops extra shapes of a shape array

SCENE_BUILDERS: dict[str, Callable[[int], Layout]] = {
    "office_A": office_a,
    "office_B": office_b,
    "house_A": house_a,
    "house_B": house_b,
}


def available_scenes() -> list[str]:
    return list(SCENE_BUILDERS)


def make_scene(name: str, client: int, seed: int = 0) -> "Scene":
    """Build the layout `name` (furniture placement depends on `seed`) into `client`."""
    if name not in SCENE_BUILDERS:
        raise ValueError(f"unknown scene {name!r}; valid scenes: {available_scenes()}")
    return Scene(SCENE_BUILDERS[name](seed), client, seed)


def _spawn_compound(boxes: list[Box], client: int) -> int:
    n = len(boxes)
    half = [list(b.half_extents) for b in boxes]
    pos = [list(b.center) for b in boxes]
    visual = -1
    if boxes[0].visible:
        visual = p.createVisualShapeArray([p.GEOM_BOX] * n, halfExtents=half, visualFramePositions=pos,
                                          physicsClientId=client)
    collision = -1
    if boxes[0].collides:
        collision = box_collision_shape(client, half, pos, compound=True)
    body = record_body(client, p.createMultiBody(0.0, collision, visual, [0, 0, 0], useMaximalCoordinates=True,
                                                 physicsClientId=client), {-1: collision})
    if visual >= 0:
        p.changeVisualShape(body, -1, rgbaColor=list(boxes[0].rgba), physicsClientId=client)
    return body


def spawn_boxes(boxes: list[Box], client: int) -> dict[str, list[int]]:
    """Spawn boxes grouped by (kind, colour, collides, visible); returns body ids per kind."""
    groups: dict[tuple, list[Box]] = defaultdict(list)
    for b in boxes:
        groups[(b.kind, b.rgba, b.collides, b.visible)].append(b)
    bodies: dict[str, list[int]] = defaultdict(list)
    for (kind, *_), members in groups.items():
        for i in range(0, len(members), MAX_SHAPES_PER_COMPOUND):
            bodies[kind].append(_spawn_compound(members[i:i + MAX_SHAPES_PER_COMPOUND], client))
    return dict(bodies)


class Scene:
    """A spawned layout. Attributes mirror the `Layout`; see the module docstrings of
    `office` and `house` for what each scene family provides."""

    def __init__(self, layout: Layout, client: int, seed: int = 0):
        self.layout = layout
        self.name, self.kind, self.seed, self.client = layout.name, layout.kind, seed, client
        self.bounds: Rect = layout.bounds
        self.regions: dict[str, Rect] = layout.regions
        self.doorways: list[Doorway] = layout.doorways
        self.start_region: str | None = layout.start_region
        self.goal_region: str | None = layout.goal_region
        self.goal_doorway: Doorway | None = self._doorway_between(self.start_region, self.goal_region)
        self.kitchen_walls: list[WallSegment] = layout.kitchen_walls
        self.tables: dict[str, Table] = layout.tables
        self.tabletop_spots: list[tuple[float, float, float]] = layout.tabletop_spots
        self.body_ids: dict[str, list[int]] = spawn_boxes(layout.boxes + layout.floor_tiles, client)
        self.static_body_ids: list[int] = sorted(
            i for kind, ids in self.body_ids.items() if kind != "floor_tile" for i in ids)
        self.floor_body_id: int = self.body_ids["floor"][0]
        for t in self.tables.values():
            t.body_id = self.body_ids["table" if t.name == "dining_table" else "reach_table"][0]
        self.trav_map = TraversabilityMap.from_boxes(self.bounds, layout.boxes)

    @property
    def table(self) -> Table | None:
        """The dining table (house scenes)."""
        return self.tables.get("dining_table")

    @property
    def reach_table(self) -> Table | None:
        """The table for TabletopReachM (house scenes); robot poses in `tabletop_spots`."""
        return self.tables.get("reach_table")

    def _doorway_between(self, a: str | None, b: str | None) -> Doorway | None:
        matches = [d for d in self.doorways if a and b and d.joins(a, b)]
        return matches[0] if matches else None

    def region_of(self, xy) -> str | None:
        """Name of the region containing `xy` (None in walls and doorway gaps)."""
        return next((name for name, r in self.regions.items() if r.contains(xy)), None)

    def doorways_of(self, region: str) -> list[Doorway]:
        return [d for d in self.doorways if region in d.regions]

    def _region_rect(self, region: str | None) -> Rect | None:
        if region is None:
            return None
        if region not in self.regions:
            raise ValueError(f"unknown region {region!r}; regions: {list(self.regions)}")
        return self.regions[region]

    def geodesic_field(self, goal_xy, robot_radius: float = ROBOT_RADIUS) -> GeodesicField:
        """Solve the shortest-path field to `goal_xy` once; query it every step."""
        return GeodesicField(self.trav_map, goal_xy, robot_radius)

    def sample_free_point(self, rng: np.random.Generator, region: str | None = None,
                          clearance: float = ROBOT_RADIUS + FREE_POINT_MARGIN) -> np.ndarray:
        return sample_free_point(self.trav_map, rng, self._region_rect(region), clearance)

    def sample_start_goal(self, rng: np.random.Generator, min_geodesic: float = 1.0, max_geodesic: float = 10.0,
                          start_region: str | None = None, goal_region: str | None = None,
                          robot_radius: float = ROBOT_RADIUS) -> StartGoal:
        """Start xy, yaw and goal xy with geodesic distance in range (plus the goal's field)."""
        return sample_start_goal(self.trav_map, rng, min_geodesic, max_geodesic, self._region_rect(start_region),
                                 self._region_rect(goal_region), robot_radius, robot_radius + FREE_POINT_MARGIN)

    def remove(self) -> None:
        """Delete every body of the scene from its client."""
        for ids in self.body_ids.values():
            for i in ids:
                p.removeBody(i, physicsClientId=self.client)
        self.body_ids, self.static_body_ids = {}, []
