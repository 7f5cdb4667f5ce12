"""House layouts for the mobile-manipulation tasks (`house_A`, `house_B`).

Each house has a kitchen (three free walls for cabinets, exposed as `kitchen_walls`), a
dining area joined to it by a 1.6 m opening with a dining table whose long sides have two
~0.6 m gaps between legs (for tucking chairs), and a living room with a second table for
TabletopReachM (`reach_table` and robot poses in front of it, `tabletop_spots`).
"""

from __future__ import annotations

import math

import numpy as np

from relmogen.scenes.floorplan import (COLOURS, DoorSpec, build_shell, doorway_keepout, floor_boxes,
                                       place_against_walls, shelf, sideboard, sofa, table)
from relmogen.scenes.geometry import Layout, Rect, Table, WallSegment

DINING_TABLE = dict(length=1.4, width=0.8, legs_per_side=3)  # leg gaps ~0.6 m
REACH_TABLE = dict(length=1.2, width=0.7, legs_per_side=2)
TABLETOP_STANDOFF = 0.5  # robot centre to the table's front edge, metres

WALL_FACES = ("west", "east", "south", "north")


def wall_face(region: Rect, name: str, side: str) -> WallSegment:
    """The full inner face of one wall of `region`, normal pointing into the room."""
    r = region
    faces = {
        "west": ((r.xmin, r.ymin), (r.xmin, r.ymax), 0.0),
        "east": ((r.xmax, r.ymax), (r.xmax, r.ymin), math.pi),
        "south": ((r.xmax, r.ymin), (r.xmin, r.ymin), 0.5 * math.pi),
        "north": ((r.xmin, r.ymax), (r.xmax, r.ymax), -0.5 * math.pi),
    }
    start, end, yaw = faces[side]
    return WallSegment(start, end, yaw, name)


def tabletop_spots(t: Table, front_yaw: float, offsets=(-0.3, 0.0, 0.3)) -> list[tuple[float, float, float]]:
    """Robot base poses (x, y, yaw) facing the table from its side at `front_yaw`."""
    out = np.array([math.cos(front_yaw), math.sin(front_yaw)])
    along = np.array([-out[1], out[0]])
    half_depth = 0.5 * (t.width if abs(math.cos(front_yaw - t.yaw)) < 0.5 else t.length)
    edge = np.asarray(t.center) + out * (half_depth + TABLETOP_STANDOFF)
    facing = math.remainder(front_yaw + math.pi, 2 * math.pi)
    return [(float(p[0]), float(p[1]), facing) for p in (edge + s * along for s in offsets)]


def _house_layout(name, rooms, doors, dining_yaw, kitchen_sides, reach_center, reach_yaw,
                  reach_front_yaw, furniture, seed) -> Layout:
    rng = np.random.default_rng(seed)
    boxes, regions, doorways, bounds = build_shell(rooms, doors)
    dining_boxes, dining = table("dining_table", regions["dining"].center, dining_yaw, **DINING_TABLE)
    reach_boxes, reach = table("reach_table", reach_center, reach_yaw, kind="reach_table", **REACH_TABLE)
    boxes += dining_boxes + reach_boxes
    keepouts = [doorway_keepout(d) for d in doorways]
    keepouts += [dining.footprint.shrunk(-1.2), reach.footprint.shrunk(-1.2)]
    for room, items in furniture.items():
        boxes += place_against_walls(rng, regions[room], items, keepouts)
    tiles = {"kitchen": COLOURS["floor_tiles"], "dining": COLOURS["floor_wood"], "living": COLOURS["floor_wood"]}
    slab, tile_boxes = floor_boxes(bounds, regions, doorways, tiles)
    return Layout(name, "house", bounds, slab + boxes, regions, doorways, tile_boxes,
                  kitchen_walls=[wall_face(regions["kitchen"], "kitchen", s) for s in kitchen_sides],
                  tables={"dining_table": dining, "reach_table": reach},
                  tabletop_spots=tabletop_spots(reach, reach_front_yaw))


def house_a(seed: int = 0) -> Layout:
    """Kitchen (west) | dining (east) in the south half, living room across the north. 11 x 8.5 m."""
    rooms = {"kitchen": (0.0, 0.0, 5.0, 4.5), "dining": (5.0, 0.0, 11.0, 4.5), "living": (0.0, 4.5, 11.0, 8.5)}
    doors = [DoorSpec("kitchen", "dining", width=1.6), DoorSpec("dining", "living", offset=4.5)]
    reach_center = (3.0, 8.44 - 0.02 - 0.35)  # back edge against the north wall
    furniture = {"dining": [(sideboard, 1.6, 0.45)], "living": [(sofa, 2.0, 0.9), (shelf, 0.9, 0.4)]}
    return _house_layout("house_A", rooms, doors, 0.0, ("west", "south", "north"), reach_center, 0.0,
                         -0.5 * math.pi, furniture, seed)


def house_b(seed: int = 0) -> Layout:
    """Kitchen (north-west) over dining (south-west), living room along the east. 10.5 x 9 m."""
    rooms = {"kitchen": (0.0, 4.5, 5.5, 9.0), "dining": (0.0, 0.0, 5.5, 4.5), "living": (5.5, 0.0, 10.5, 9.0)}
    doors = [DoorSpec("dining", "kitchen", width=1.6), DoorSpec("dining", "living", offset=3.0)]
    reach_center = (10.44 - 0.02 - 0.35, 6.5)  # back edge against the east wall
    furniture = {"dining": [(sideboard, 1.6, 0.45)], "living": [(sofa, 2.0, 0.9), (shelf, 0.9, 0.4)]}
    return _house_layout("house_B", rooms, doors, 0.5 * math.pi, ("west", "north", "east"), reach_center,
                         0.5 * math.pi, math.pi, furniture, seed)
