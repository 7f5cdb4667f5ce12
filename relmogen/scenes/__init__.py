"""Procedural indoor scenes (offices, houses) built from PyBullet boxes, with navigation maps.

    scene = make_scene("office_A", client, seed=0)
    field = scene.geodesic_field(goal_xy)          # once per goal
    field.distance(xy), field.waypoints(xy)        # every step
"""

from relmogen.scenes.geometry import Box, Doorway, Layout, Rect, Table, WallSegment
from relmogen.scenes.navigation import (ROBOT_RADIUS, GeodesicField, StartGoal, TraversabilityMap,
                                        sample_free_point, sample_start_goal)
from relmogen.scenes.scene import Scene, available_scenes, make_scene

__all__ = [
    "Box", "Doorway", "GeodesicField", "Layout", "ROBOT_RADIUS", "Rect", "Scene", "StartGoal", "Table",
    "TraversabilityMap", "WallSegment", "available_scenes", "make_scene", "sample_free_point",
    "sample_start_goal",
]
