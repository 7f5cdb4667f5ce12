"""Plain geometry records that describe a scene layout (no PyBullet here).

Everything is axis-aligned: a scene is a list of `Box` primitives plus named floor
regions (`Rect`), the `Doorway`s joining them and a few semantic records (tables, wall
segments for cabinets). The PyBullet builder and the traversability map both consume
these records, so the map is exactly the geometry that was spawned.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from relmogen.simulation.frames import FacesYaw

RGBA = tuple[float, float, float, float]


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle [xmin, xmax] x [ymin, ymax] in world metres."""

    xmin: float
    ymin: float
    xmax: float
    ymax: float

    @property
    def center(self) -> tuple[float, float]:
        return (0.5 * (self.xmin + self.xmax), 0.5 * (self.ymin + self.ymax))

    @property
    def size(self) -> tuple[float, float]:
        return (self.xmax - self.xmin, self.ymax - self.ymin)

    @property
    def area(self) -> float:
        return self.size[0] * self.size[1]

    def contains(self, xy, margin: float = 0.0) -> bool:
        x, y = float(xy[0]), float(xy[1])
        return (self.xmin + margin <= x <= self.xmax - margin
                and self.ymin + margin <= y <= self.ymax - margin)

    def shrunk(self, d: float) -> "Rect":
        return Rect(self.xmin + d, self.ymin + d, self.xmax - d, self.ymax - d)

    def intersects(self, other: "Rect") -> bool:
        return (self.xmin < other.xmax and other.xmin < self.xmax
                and self.ymin < other.ymax and other.ymin < self.ymax)

    @staticmethod
    def around(center, size) -> "Rect":
        cx, cy = center
        hx, hy = 0.5 * size[0], 0.5 * size[1]
        return Rect(cx - hx, cy - hy, cx + hx, cy + hy)


@dataclass(frozen=True)
class Box:
    """A static axis-aligned box: centre (x, y, z), half extents, colour and class."""

    center: tuple[float, float, float]
    half_extents: tuple[float, float, float]
    rgba: RGBA
    kind: str  # e.g. "wall", "desk", "table"; boxes of one kind share PyBullet bodies
    collides: bool = True
    visible: bool = True

    @property
    def footprint(self) -> Rect:
        return Rect.around(self.center[:2], (2 * self.half_extents[0], 2 * self.half_extents[1]))

    @property
    def z_range(self) -> tuple[float, float]:
        return (self.center[2] - self.half_extents[2], self.center[2] + self.half_extents[2])


@dataclass(frozen=True)
class Doorway(FacesYaw):
    """An opening in a wall joining two regions.

    `yaw` is the direction of the wall normal pointing from `regions[0]` into
    `regions[1]` (`normal`; `along` runs along the wall); `width` is the clear opening;
    `wall_thickness` the depth of the gap.
    """

    center: tuple[float, float]
    yaw: float
    width: float
    regions: tuple[str, str]
    wall_thickness: float
    height: float  # clear height under the lintel

    def joins(self, a: str, b: str) -> bool:
        return set(self.regions) == {a, b}

    def point_in_front(self, region: str, distance: float) -> np.ndarray:
        """Point `distance` metres from the doorway centre, inside `region`."""
        sign = 1.0 if region == self.regions[1] else -1.0
        if region not in self.regions:
            raise ValueError(f"doorway joins {self.regions}, not {region!r}")
        return np.asarray(self.center) + sign * distance * self.normal


@dataclass(frozen=True)
class WallSegment:
    """A free stretch of a wall's inner face, e.g. for cabinets.

    `start`/`end` lie on the face; `normal_yaw` points into the room.
    """

    start: tuple[float, float]
    end: tuple[float, float]
    normal_yaw: float
    region: str

    @property
    def length(self) -> float:
        return math.dist(self.start, self.end)

    @property
    def direction(self) -> np.ndarray:
        d = np.subtract(self.end, self.start)
        return d / np.linalg.norm(d)

    def point_at(self, s: float) -> np.ndarray:
        """Point on the face `s` metres from `start`."""
        return np.asarray(self.start) + s * self.direction


@dataclass
class Table:
    """A four-or-six-legged table. Long side along the local x axis, rotated by `yaw`."""

    name: str
    center: tuple[float, float]
    yaw: float  # 0 or pi/2
    length: float
    width: float
    height: float  # top surface z
    top_thickness: float
    leg_size: float
    leg_positions: list[tuple[float, float]]  # world xy of leg centres
    # Gaps between legs on the long sides: (world xy of the gap centre at the table edge,
    # yaw of the outward normal, clear width between the leg faces).
    side_gaps: list[tuple[tuple[float, float], float, float]]
    body_id: int = -1

    @property
    def footprint(self) -> Rect:
        size = (self.length, self.width) if abs(math.sin(self.yaw)) < 0.5 else (self.width, self.length)
        return Rect.around(self.center, size)


@dataclass
class Layout:
    """Everything a scene builder produces, before anything is spawned."""

    name: str
    kind: str  # "office" or "house"
    bounds: Rect  # outer faces of the building
    boxes: list[Box]
    regions: dict[str, Rect]
    doorways: list[Doorway]
    floor_tiles: list[Box] = field(default_factory=list)  # visual only
    start_region: str | None = None
    goal_region: str | None = None
    kitchen_walls: list[WallSegment] = field(default_factory=list)
    tables: dict[str, Table] = field(default_factory=dict)
    tabletop_spots: list[tuple[float, float, float]] = field(default_factory=list)
