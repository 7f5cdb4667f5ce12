"""Local occupancy map built from one LiDAR scan.

The map is a square window centred on the robot and aligned with the robot's base frame.
Cell ``[i, j]`` covers the point ``x = (i + 0.5) * res - half``, ``y = (j + 0.5) * res - half``
in the robot frame (``x`` forward, ``y`` left). Cell values (uint8, so the map can be fed to a
CNN as an image):

* ``FREE = 0``       seen free by a ray, or under the robot's own footprint
* ``UNKNOWN = 128``  not observed (behind the LiDAR's field of view, or behind a hit)
* ``OCCUPIED = 255`` a ray ended here
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from relmogen.simulation.frames import to_local, to_world

FREE = np.uint8(0)
UNKNOWN = np.uint8(128)
OCCUPIED = np.uint8(255)


@dataclass(frozen=True)
class LocalMap:
    """An occupancy grid in the robot frame at the moment of the scan."""

    grid: np.ndarray  # (N, N) uint8 with FREE / UNKNOWN / OCCUPIED
    resolution: float  # metres per cell
    robot_pose: tuple[float, float, float]  # world (x, y, yaw) of the robot when scanned

    @property
    def size(self) -> int:
        return self.grid.shape[0]

    @property
    def half_extent(self) -> float:
        return 0.5 * self.size * self.resolution

    def point_to_cell(self, xy_robot: np.ndarray) -> np.ndarray:
        """Robot-frame points (..., 2) to integer cells (..., 2); may fall outside the grid."""
        return np.floor((np.asarray(xy_robot) + self.half_extent) / self.resolution).astype(np.int64)

    def cell_to_point(self, cells: np.ndarray) -> np.ndarray:
        """Integer cells (..., 2) to robot-frame cell centres (..., 2)."""
        return (np.asarray(cells) + 0.5) * self.resolution - self.half_extent

    def contains(self, xy_robot: np.ndarray) -> np.ndarray:
        cells = self.point_to_cell(xy_robot)
        return np.all((cells >= 0) & (cells < self.size), axis=-1)

    def world_to_robot(self, xy_world: np.ndarray) -> np.ndarray:
        return to_local(xy_world, self.robot_pose)

    def robot_to_world(self, xy_robot: np.ndarray) -> np.ndarray:
        return to_world(xy_robot, self.robot_pose)


def build_local_map(
    ranges: np.ndarray,
    angles: np.ndarray,
    lidar_xy: tuple[float, float],
    max_range: float,
    robot_pose: tuple[float, float, float],
    footprint_radius: float,
    size_m: float = 5.0,
    resolution: float = 0.05,
) -> LocalMap:
    """Rasterise a scan into a LocalMap.

    ``ranges`` are metres along ``angles`` (radians, robot frame) from the LiDAR at ``lidar_xy``
    (robot frame). A range of ``max_range`` or more means the ray hit nothing: the whole ray
    is free (so an empty room is free space, not unknown).
    """
    n = int(round(size_m / resolution))
    grid = np.full((n, n), UNKNOWN, dtype=np.uint8)
    half = 0.5 * n * resolution
    ranges = np.minimum(np.asarray(ranges, dtype=np.float64), max_range)
    angles = np.asarray(angles, dtype=np.float64)
    lidar = tuple(float(v) for v in lidar_xy)
    steps, cells = _ray_cells(angles.tobytes(), lidar, float(max_range), n, float(resolution))
    free = (steps[None, :] < ranges[:, None]) & (cells >= 0)
    grid.ravel()[cells[free]] = FREE
    hits = ranges < max_range
    hit_pts = np.asarray(lidar) + ranges[hits, None] * np.stack([np.cos(angles[hits]), np.sin(angles[hits])], axis=-1)
    _mark(grid, hit_pts, resolution, half, OCCUPIED)
    grid[_footprint_disc(n, float(footprint_radius), float(resolution))] = FREE
    return LocalMap(grid=grid, resolution=resolution, robot_pose=tuple(float(v) for v in robot_pose))


@functools.lru_cache(maxsize=16)
def _ray_cells(angles_bytes: bytes, lidar_xy: tuple[float, float], max_range: float, n: int,
               resolution: float) -> tuple[np.ndarray, np.ndarray]:
    """The sample distances along every ray (every half cell) and the flat grid cell of each
    sample (-1 outside the window), (R, S). A robot's LiDAR never moves in its base frame, so a
    map is these cells cut at each ray's range: computed once per LiDAR and map geometry."""
    angles = np.frombuffer(angles_bytes, dtype=np.float64)
    half = 0.5 * n * resolution
    # The window's corner is at most half*sqrt(2) from the robot; no need to march further.
    reach = min(max_range, half * np.sqrt(2.0) + np.hypot(*lidar_xy))
    steps = np.arange(0.0, reach, 0.5 * resolution)
    dirs = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    pts = np.asarray(lidar_xy) + steps[None, :, None] * dirs[:, None, :]
    cells = np.floor((pts + half) / resolution).astype(np.int64)
    inside = np.all((cells >= 0) & (cells < n), axis=-1)
    flat = np.where(inside, cells[..., 0] * n + cells[..., 1], -1)
    steps.flags.writeable = flat.flags.writeable = False
    return steps, flat


def _mark(grid: np.ndarray, pts: np.ndarray, resolution: float, half: float, value: np.uint8) -> None:
    cells = np.floor((pts + half) / resolution).astype(np.int64)
    n = grid.shape[0]
    inside = np.all((cells >= 0) & (cells < n), axis=-1)
    cells = cells[inside]
    grid[cells[:, 0], cells[:, 1]] = value


@functools.lru_cache(maxsize=16)
def _footprint_disc(n: int, radius: float, resolution: float) -> np.ndarray:
    """(n, n) bool: the cells whose centre lies under the robot's footprint disc."""
    half = 0.5 * n * resolution
    centres = (np.arange(n) + 0.5) * resolution - half
    inside = centres[:, None] ** 2 + centres[None, :] ** 2 <= radius**2
    inside.flags.writeable = False
    return inside
