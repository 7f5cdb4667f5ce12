"""Synthetic local maps for the motion-generation tests and measurement script."""

from __future__ import annotations

import numpy as np

from relmogen.simulation.occupancy import FREE, OCCUPIED, LocalMap

SIZE = 100  # 5 m at 0.05 m
RESOLUTION = 0.05
ROBOT_POSE = (1.0, -2.0, 0.7)  # non-trivial world pose to exercise the frame conversion


def empty_map(robot_pose=ROBOT_POSE) -> LocalMap:
    return LocalMap(np.full((SIZE, SIZE), FREE, dtype=np.uint8), RESOLUTION, robot_pose)


def _coords() -> np.ndarray:
    return (np.arange(SIZE) + 0.5) * RESOLUTION - 0.5 * SIZE * RESOLUTION


def doorway_map(wall_x: float = 1.0, gap_centre_y: float = 0.5, gap: float = 1.0) -> LocalMap:
    """A 0.1 m thick wall at ``wall_x`` across the window with a ``gap`` m opening."""
    c = _coords()
    grid = np.full((SIZE, SIZE), FREE, dtype=np.uint8)
    wall_rows = np.abs(c - wall_x) <= 0.05
    in_gap = np.abs(c - gap_centre_y) < 0.5 * gap
    grid[np.ix_(wall_rows, ~in_gap)] = OCCUPIED
    return LocalMap(grid, RESOLUTION, ROBOT_POSE)


def cluttered_map(rng: np.random.Generator, n_obstacles: int = 12) -> LocalMap:
    """Random square boxes (0.15-0.4 m) kept at least 0.7 m from the robot."""
    c = _coords()
    grid = np.full((SIZE, SIZE), FREE, dtype=np.uint8)
    placed = 0
    while placed < n_obstacles:
        centre = rng.uniform(-2.2, 2.2, size=2)
        half = rng.uniform(0.075, 0.2)
        if np.hypot(*centre) < 0.7 + half:
            continue
        rows = np.abs(c - centre[0]) <= half
        cols = np.abs(c - centre[1]) <= half
        grid[np.ix_(rows, cols)] = OCCUPIED
        placed += 1
    return LocalMap(grid, RESOLUTION, ROBOT_POSE)


def random_free_goal(local_map: LocalMap, rng: np.random.Generator, min_distance: float = 1.5):
    """A robot-frame (x, y, yaw) goal whose footprint is free, at least ``min_distance`` away."""
    from relmogen.motion_generation.base_planner import FETCH_FOOTPRINT_RADIUS, FootprintChecker

    checker = FootprintChecker(local_map, FETCH_FOOTPRINT_RADIUS)
    while True:
        goal = np.array([*rng.uniform(-2.2, 2.2, size=2), rng.uniform(-np.pi, np.pi)])
        if np.hypot(*goal[:2]) >= min_distance and not checker.footprint_hits_obstacle(goal):
            return goal
