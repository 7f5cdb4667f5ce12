"""Office floor layouts for the navigation tasks (`office_A`, `office_B`).

Both have a ~2 m corridor with rooms of 4.5-6 m off it, 1 m doorways, and desks and
shelves against the walls (placed by the seed). The start region is the corridor; the goal
region is a room whose only doorway opens onto the corridor (`goal_doorway`, listed as
(corridor, goal room) so its normal points into the goal room), which is where the
interactive tasks put their door, button or obstacles. `DoorSpec.offset` is measured from
the low end of the wall shared by the two rooms.
"""

from __future__ import annotations

import numpy as np

from relmogen.scenes.floorplan import (COLOURS, DoorSpec, build_shell, desk, doorway_keepout, floor_boxes,
                                       place_against_walls, shelf)
from relmogen.scenes.geometry import Layout

DESK = (desk, 1.4, 0.7)
SHELF = (shelf, 0.9, 0.4)

# Rooms on wall centre lines (x0, y0, x1, y1), metres.
OFFICE_A_ROOMS = {
    "corridor": (0.0, 5.0, 18.0, 7.0),
    "office_1": (0.0, 0.0, 6.0, 5.0),
    "office_2": (6.0, 0.0, 12.0, 5.0),
    "office_3": (12.0, 0.0, 18.0, 5.0),
    "meeting_room": (0.0, 7.0, 5.0, 12.0),
    "office_4": (5.0, 7.0, 10.5, 12.0),
    "open_office": (10.5, 7.0, 18.0, 12.0),
}
OFFICE_A_DOORS = [
    DoorSpec("corridor", "office_1", offset=4.8),
    DoorSpec("office_1", "office_2", offset=1.2),
    DoorSpec("corridor", "office_2", offset=4.0),
    DoorSpec("corridor", "office_3", offset=1.3),
    DoorSpec("corridor", "meeting_room", offset=3.8),
    DoorSpec("corridor", "office_4", offset=1.0),
    DoorSpec("corridor", "open_office", offset=5.0),
]
OFFICE_A_FURNITURE = {
    "office_1": [DESK, DESK, SHELF],
    "office_2": [DESK, DESK, SHELF],
    "office_3": [DESK, DESK, SHELF],
    "meeting_room": [SHELF, SHELF],
    "office_4": [DESK, DESK, SHELF],
    "open_office": [DESK, DESK, DESK, DESK, SHELF],
}

# Vertical corridor, three rooms on the west side, a lab and a lounge on the east.
OFFICE_B_ROOMS = {
    "corridor": (6.0, 0.0, 8.0, 14.0),
    "office_1": (0.0, 0.0, 6.0, 4.5),
    "office_2": (0.0, 4.5, 6.0, 9.5),
    "meeting_room": (0.0, 9.5, 6.0, 14.0),
    "office_3": (8.0, 0.0, 13.0, 5.0),
    "lab": (8.0, 5.0, 13.0, 10.0),
    "lounge": (8.0, 10.0, 13.0, 14.0),
}
OFFICE_B_DOORS = [
    DoorSpec("office_1", "corridor", offset=3.2),
    DoorSpec("corridor", "office_2", offset=2.5),
    DoorSpec("meeting_room", "corridor", offset=2.0),
    DoorSpec("corridor", "office_3", offset=1.5),
    DoorSpec("corridor", "lab", offset=3.5),
    DoorSpec("lab", "lounge", offset=3.5),
    DoorSpec("corridor", "lounge", offset=2.5),
]
OFFICE_B_FURNITURE = {
    "office_1": [DESK, DESK, SHELF],
    "office_2": [DESK, DESK, SHELF],
    "meeting_room": [SHELF, SHELF],
    "office_3": [DESK, DESK],
    "lab": [DESK, DESK, DESK, SHELF],
    "lounge": [SHELF],
}


def _office_layout(name, rooms, doors, furniture, goal_region, seed) -> Layout:
    rng = np.random.default_rng(seed)
    boxes, regions, doorways, bounds = build_shell(rooms, doors)
    keepouts = [doorway_keepout(d) for d in doorways]
    for room, items in furniture.items():
        boxes += place_against_walls(rng, regions[room], items, keepouts)
    tiles = {r: COLOURS["floor_corridor" if r == "corridor" else "floor_office"] for r in regions}
    slab, tile_boxes = floor_boxes(bounds, regions, doorways, tiles)
    return Layout(name, "office", bounds, slab + boxes, regions, doorways, tile_boxes,
                  start_region="corridor", goal_region=goal_region)


def office_a(seed: int = 0) -> Layout:
    """Horizontal corridor, three offices south (two joined), three rooms north. 18 x 12 m."""
    return _office_layout("office_A", OFFICE_A_ROOMS, OFFICE_A_DOORS, OFFICE_A_FURNITURE, "office_3", seed)


def office_b(seed: int = 0) -> Layout:
    """Vertical corridor, three rooms west, three east (lab and lounge joined). 13 x 14 m."""
    return _office_layout("office_B", OFFICE_B_ROOMS, OFFICE_B_DOORS, OFFICE_B_FURNITURE, "office_2", seed)
