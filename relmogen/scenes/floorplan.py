"""Turn a room list into walls, doorways and regions, and build furniture from boxes.

Rooms are given on wall centre lines; each room edge becomes wall, shared edges are
merged, and `DoorSpec`s cut gaps (with a lintel above) into the shared edge of two rooms.
Furniture helpers return `Box` lists; `place_against_walls` puts items with their back to
a wall, away from doorways, using a seeded generator.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass

import numpy as np

from relmogen.scenes.geometry import RGBA, Box, Doorway, Rect, Table

WALL_THICKNESS = 0.12
WALL_HEIGHT = 2.5
DOOR_HEIGHT = 2.1

COLOURS: dict[str, RGBA] = {
    "floor": (0.62, 0.62, 0.62, 1.0),
    "wall": (0.93, 0.91, 0.86, 1.0),
    "floor_corridor": (0.74, 0.75, 0.77, 1.0),
    "floor_office": (0.50, 0.56, 0.62, 1.0),  # blue-grey carpet
    "floor_wood": (0.72, 0.58, 0.42, 1.0),
    "floor_tiles": (0.86, 0.86, 0.82, 1.0),
    "desk": (0.55, 0.38, 0.22, 1.0),
    "shelf": (0.38, 0.26, 0.16, 1.0),
    "cabinet": (0.45, 0.47, 0.50, 1.0),
    "sofa": (0.28, 0.34, 0.46, 1.0),
    "table": (0.60, 0.42, 0.25, 1.0),
    "reach_table": (0.80, 0.78, 0.72, 1.0),
}


@dataclass(frozen=True)
class DoorSpec:
    """A gap of `width` in the wall shared by rooms `a` and `b`.

    `offset` is the gap centre measured along the shared edge from its low end
    (None = middle). The doorway normal points from `a` to `b`.
    """

    a: str
    b: str
    width: float = 1.0
    offset: float | None = None


def _key(v: float) -> float:
    return round(v, 6)


def _merge(intervals: list[tuple[float, float]]) -> list[tuple[float, float]]:
    merged: list[list[float]] = []
    for lo, hi in sorted(intervals):
        if merged and lo <= merged[-1][1] + 1e-9:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return [(lo, hi) for lo, hi in merged]


def _subtract(interval: tuple[float, float], gaps: list[tuple[float, float]]):
    pieces, lo = [], interval[0]
    for g0, g1 in sorted(gaps):
        if g1 <= lo or g0 >= interval[1]:
            continue
        if g0 > lo:
            pieces.append((lo, g0))
        lo = max(lo, g1)
    if lo < interval[1]:
        pieces.append((lo, interval[1]))
    return pieces


def _wall_box(axis: str, coord: float, lo: float, hi: float, z0: float, z1: float) -> Box:
    t = WALL_THICKNESS
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    zc, hz = 0.5 * (z0 + z1), 0.5 * (z1 - z0)
    if axis == "h":  # wall along x at y = coord
        return Box((mid, coord, zc), (half, 0.5 * t, hz), COLOURS["wall"], "wall")
    return Box((coord, mid, zc), (0.5 * t, half, hz), COLOURS["wall"], "wall")


def _shared_edge(ra, rb):
    """(axis, coord, lo, hi, yaw a->b) of the edge shared by two centre-line rects."""
    ax0, ay0, ax1, ay1 = ra
    bx0, by0, bx1, by1 = rb
    for coord, axis, yaw in ((ax1, "v", 0.0), (ax0, "v", math.pi), (ay1, "h", 0.5 * math.pi),
                             (ay0, "h", -0.5 * math.pi)):
        other = {"v": (bx0 if yaw == 0.0 else bx1), "h": (by0 if yaw > 0 else by1)}[axis]
        if abs(coord - other) > 1e-6:
            continue
        lo, hi = ((max(ay0, by0), min(ay1, by1)) if axis == "v" else (max(ax0, bx0), min(ax1, bx1)))
        if hi - lo > 1e-6:
            return axis, coord, lo, hi, yaw
    raise ValueError(f"rooms {ra} and {rb} share no wall")


def build_shell(rooms: dict[str, tuple[float, float, float, float]], doors: list[DoorSpec]):
    """Walls (with doorway gaps and lintels), regions, doorways and the building bounds."""
    lines: dict[tuple[str, float], list] = defaultdict(list)
    for x0, y0, x1, y1 in rooms.values():
        lines[("h", _key(y0))].append((x0, x1))
        lines[("h", _key(y1))].append((x0, x1))
        lines[("v", _key(x0))].append((y0, y1))
        lines[("v", _key(x1))].append((y0, y1))
    gaps: dict[tuple[str, float], list] = defaultdict(list)
    doorways, boxes = [], []
    for spec in doors:
        axis, coord, lo, hi, yaw = _shared_edge(rooms[spec.a], rooms[spec.b])
        centre = lo + (0.5 * (hi - lo) if spec.offset is None else spec.offset)
        if centre - 0.5 * spec.width < lo + WALL_THICKNESS or centre + 0.5 * spec.width > hi - WALL_THICKNESS:
            raise ValueError(f"doorway {spec} does not fit on its wall")
        gap = (centre - 0.5 * spec.width, centre + 0.5 * spec.width)
        gaps[(axis, _key(coord))].append(gap)
        boxes.append(_wall_box(axis, coord, *gap, DOOR_HEIGHT, WALL_HEIGHT))  # lintel
        xy = (coord, centre) if axis == "v" else (centre, coord)
        doorways.append(Doorway(xy, yaw, spec.width, (spec.a, spec.b), WALL_THICKNESS, DOOR_HEIGHT))
    half_t = 0.5 * WALL_THICKNESS
    for (axis, coord), intervals in lines.items():
        for lo, hi in _merge(intervals):
            for a, b in _subtract((lo - half_t, hi + half_t), gaps[(axis, coord)]):
                boxes.append(_wall_box(axis, coord, a, b, 0.0, WALL_HEIGHT))
    regions = {name: Rect(x0, y0, x1, y1).shrunk(half_t) for name, (x0, y0, x1, y1) in rooms.items()}
    xs = [v for r in rooms.values() for v in (r[0], r[2])]
    ys = [v for r in rooms.values() for v in (r[1], r[3])]
    bounds = Rect(min(xs) - half_t, min(ys) - half_t, max(xs) + half_t, max(ys) + half_t)
    return boxes, regions, doorways, bounds


def floor_boxes(bounds: Rect, regions: dict[str, Rect], doorways: list[Doorway],
                tile_colours: dict[str, RGBA]):
    """An invisible collision floor slab plus thin visual-only tiles per region and doorway.

    The slab is invisible because TinyRenderer rasterises one huge floor slowly (~3 ms
    per 128x128 image); the room-sized tiles are cheaper and give each room its colour.
    """
    cx, cy = bounds.center
    sx, sy = bounds.size
    slab = Box((cx, cy, -0.05), (0.5 * sx + 1.0, 0.5 * sy + 1.0, 0.05), COLOURS["floor"], "floor",
               visible=False)
    rects = [(r, tile_colours[name]) for name, r in regions.items()]
    for d in doorways:
        size = np.abs(d.normal) * d.wall_thickness + np.abs(d.along) * d.width
        rects.append((Rect.around(d.center, size), tile_colours[d.regions[0]]))
    tiles = [Box((*r.center, 0.001), (0.5 * r.size[0], 0.5 * r.size[1], 0.001), colour, "floor_tile",
                 collides=False) for r, colour in rects]
    return [slab], tiles


def _yaw_axes(yaw: float):
    """Unit 'forward' (room-facing) and 'along wall' vectors for a multiple-of-90 yaw."""
    fwd = np.round([math.cos(yaw), math.sin(yaw)], 6)
    return fwd, np.array([-fwd[1], fwd[0]])


def _local_box(origin, yaw, local_xy, size_xy, z0, z1, kind) -> Box:
    """Box given in a frame at `origin` with x = forward (`yaw`), y = along the wall."""
    fwd, along = _yaw_axes(yaw)
    c = np.asarray(origin) + local_xy[0] * fwd + local_xy[1] * along
    sx = abs(fwd[0]) * size_xy[0] + abs(along[0]) * size_xy[1]
    sy = abs(fwd[1]) * size_xy[0] + abs(along[1]) * size_xy[1]
    return Box((float(c[0]), float(c[1]), 0.5 * (z0 + z1)), (0.5 * sx, 0.5 * sy, 0.5 * (z1 - z0)),
               COLOURS[kind], kind)


def desk(center, yaw: float, width: float = 1.4, depth: float = 0.7) -> list[Box]:
    """Desk: top slab, two side panels and a modesty panel on the wall side. `yaw` faces the user."""
    h, top, panel = 0.75, 0.04, 0.03
    return [
        _local_box(center, yaw, (0, 0), (depth, width), h - top, h, "desk"),
        _local_box(center, yaw, (0, 0.5 * (width - panel)), (depth, panel), 0, h - top, "desk"),
        _local_box(center, yaw, (0, -0.5 * (width - panel)), (depth, panel), 0, h - top, "desk"),
        _local_box(center, yaw, (-0.5 * depth + 0.1, 0), (panel, width - 2 * panel), 0.1, h - top, "desk"),
    ]


def shelf(center, yaw: float, width: float = 0.9, depth: float = 0.4, height: float = 1.8) -> list[Box]:
    return [_local_box(center, yaw, (0, 0), (depth, width), 0, height, "shelf")]


def sideboard(center, yaw: float, width: float = 1.6, depth: float = 0.45) -> list[Box]:
    return [_local_box(center, yaw, (0, 0), (depth, width), 0, 0.85, "cabinet")]


def sofa(center, yaw: float, width: float = 2.0, depth: float = 0.9) -> list[Box]:
    return [_local_box(center, yaw, (0.1, 0), (depth - 0.2, width), 0, 0.45, "sofa"),
            _local_box(center, yaw, (-0.5 * depth + 0.1, 0), (0.2, width), 0, 0.85, "sofa")]


def table(name: str, center, yaw: float, length: float, width: float, legs_per_side: int = 2,
          height: float = 0.75, kind: str = "table") -> tuple[list[Box], Table]:
    """Table with its long side along local x; `legs_per_side` > 2 adds evenly spaced legs."""
    top, leg, inset = 0.04, 0.05, 0.03
    # Rotating by 90 deg: local x (long side) maps to world y.
    along, fwd_yaw = yaw, yaw - 0.5 * math.pi
    boxes = [_local_box(center, fwd_yaw, (0, 0), (width, length), height - top, height, kind)]
    xs = np.linspace(-0.5 * length + inset + 0.5 * leg, 0.5 * length - inset - 0.5 * leg, legs_per_side)
    ys = (-0.5 * width + inset + 0.5 * leg, 0.5 * width - inset - 0.5 * leg)
    legs, gaps = [], []
    for y in ys:
        for x in xs:
            b = _local_box(center, fwd_yaw, (y, x), (leg, leg), 0, height - top, kind)
            boxes.append(b)
            legs.append((b.center[0], b.center[1]))
        for x0, x1 in zip(xs[:-1], xs[1:]):
            edge = np.asarray(center) + 0.5 * (x0 + x1) * np.array([math.cos(along), math.sin(along)])
            outward = fwd_yaw + (math.pi if y < 0 else 0.0)
            edge = edge + 0.5 * width * np.array([math.cos(outward), math.sin(outward)])
            gaps.append(((float(edge[0]), float(edge[1])), math.remainder(outward, 2 * math.pi),
                         float(x1 - x0 - leg)))
    spec = Table(name, tuple(map(float, center)), yaw, length, width, height, top, leg, legs, gaps)
    return boxes, spec


WALL_SIDES = {"south": 0.5 * math.pi, "north": -0.5 * math.pi, "west": 0.0, "east": math.pi}


def footprint_against_wall(room: Rect, side: str, along_pos: float, width: float, depth: float) -> Rect:
    """Footprint of an item of `width` x `depth` with its back on wall `side` of `room`."""
    gap = 0.02
    if side in ("south", "north"):
        y0 = room.ymin + gap if side == "south" else room.ymax - gap - depth
        return Rect(along_pos - 0.5 * width, y0, along_pos + 0.5 * width, y0 + depth)
    x0 = room.xmin + gap if side == "west" else room.xmax - gap - depth
    return Rect(x0, along_pos - 0.5 * width, x0 + depth, along_pos + 0.5 * width)


def doorway_keepout(door: Doorway, depth: float = 1.3, margin: float = 0.35) -> Rect:
    """Area on both sides of a doorway that furniture must leave free."""
    n, a = np.abs(door.normal), np.abs(door.along)
    half = n * depth + a * (0.5 * door.width + margin)
    return Rect(door.center[0] - half[0], door.center[1] - half[1],
                door.center[0] + half[0], door.center[1] + half[1])


def place_against_walls(rng: np.random.Generator, room: Rect, items, keepouts: list[Rect],
                        sides=tuple(WALL_SIDES), tries: int = 200):
    """Place (builder, width, depth) items along the walls of `room`; returns the boxes.

    Items overlapping a keepout or each other (0.6 m apart so the robot can pass between
    them) are resampled; an item that finds no spot after `tries` is skipped.
    """
    boxes, taken = [], list(keepouts)
    for builder, width, depth in items:
        for _ in range(tries):
            side = sides[rng.integers(len(sides))]
            lo, hi = ((room.xmin, room.xmax) if side in ("south", "north") else (room.ymin, room.ymax))
            if hi - lo < width + 0.1:
                continue
            pos = rng.uniform(lo + 0.5 * width + 0.05, hi - 0.5 * width - 0.05)
            fp = footprint_against_wall(room, side, pos, width, depth)
            if any(fp.intersects(t) for t in taken):
                continue
            taken.append(fp.shrunk(-0.6))
            boxes += builder(fp.center, WALL_SIDES[side], width, depth)
            break
    return boxes
