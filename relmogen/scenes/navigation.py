"""Static-floor-plan navigation maps: traversability grid, geodesic field, sampling.

`TraversabilityMap` rasterises the layout's obstacle footprints (exact, no ray casting).
`GeodesicField` runs fast marching (scikit-fmm) once per goal on the map eroded by the
robot radius; afterwards `distance` and `waypoints` are cheap per-step look-ups (bilinear
interpolation and gradient descent on the stored field). Grids are indexed [row, col] =
[y, x]; cell (0, 0) has its lower-left corner at `origin`. Distances are in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable

import numpy as np
import skfmm
from scipy import ndimage

from relmogen.scenes.geometry import Box, Rect

ROBOT_RADIUS = 0.279  # Fetch base footprint used by the original planner (the default; tasks pass the robot's)
FREE_POINT_MARGIN = 0.05  # m: sampled start/goal points are this much farther from obstacles than the robot's radius
RESOLUTION = 0.05
FIELD_RESOLUTION = 0.1
OBSTACLE_HEIGHT_RANGE = (0.03, 1.6)  # boxes spanning any of this z band block the robot
_SQRT2 = math.sqrt(2.0)


class TraversabilityMap:
    """Boolean free-space grid of the static floor plan."""

    def __init__(self, free: np.ndarray, origin: tuple[float, float], resolution: float = RESOLUTION):
        self.free = np.asarray(free, dtype=bool)
        self.origin = (float(origin[0]), float(origin[1]))
        self.resolution = float(resolution)
        self._eroded: dict[float, TraversabilityMap] = {}
        self._clearance: np.ndarray | None = None
        self._labels: np.ndarray | None = None
        self._fill: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._coarse: dict[int, TraversabilityMap] = {}
        self._candidates: dict[tuple, np.ndarray] = {}  # sampling cells per (region, clearance)

    @classmethod
    def from_rects(cls, bounds: Rect, obstacles: Iterable[Rect], resolution: float = RESOLUTION):
        """Cells inside `bounds` are free unless they overlap an obstacle rectangle.

        One blocked cell of margin surrounds `bounds`.
        """
        origin = (bounds.xmin - resolution, bounds.ymin - resolution)
        cols = int(math.ceil(bounds.size[0] / resolution)) + 2
        rows = int(math.ceil(bounds.size[1] / resolution)) + 2
        free = np.zeros((rows, cols), dtype=bool)
        free[1:-1, 1:-1] = True
        grid = cls(free, origin, resolution)
        for r in obstacles:
            grid.free[grid._cell_slice(r)] = False
        return grid

    @classmethod
    def from_boxes(cls, bounds: Rect, boxes: Iterable[Box], resolution: float = RESOLUTION):
        """Rasterise the footprints of colliding boxes that reach into the robot's height band."""
        lo, hi = OBSTACLE_HEIGHT_RANGE
        rects = [b.footprint for b in boxes if b.collides and b.z_range[0] < hi and b.z_range[1] > lo]
        return cls.from_rects(bounds, rects, resolution)

    def _cell_slice(self, r: Rect):
        """Rows/cols of every cell overlapping `r` (conservative rasterisation)."""
        eps, res = 1e-9, self.resolution
        c0 = max(int(math.floor((r.xmin - self.origin[0]) / res + eps)), 0)
        c1 = int(math.ceil((r.xmax - self.origin[0]) / res - eps))
        r0 = max(int(math.floor((r.ymin - self.origin[1]) / res + eps)), 0)
        r1 = int(math.ceil((r.ymax - self.origin[1]) / res - eps))
        return slice(r0, max(r1, r0)), slice(c0, max(c1, c0))

    @property
    def shape(self) -> tuple[int, int]:
        return self.free.shape

    @property
    def bounds(self) -> Rect:
        rows, cols = self.shape
        x0, y0 = self.origin
        return Rect(x0, y0, x0 + cols * self.resolution, y0 + rows * self.resolution)

    def world_to_cell(self, xy) -> np.ndarray:
        """(..., 2) world xy -> (..., 2) integer [row, col] (may be out of range)."""
        xy = np.asarray(xy, dtype=float)
        col = np.floor((xy[..., 0] - self.origin[0]) / self.resolution)
        row = np.floor((xy[..., 1] - self.origin[1]) / self.resolution)
        return np.stack([row, col], axis=-1).astype(int)

    def cell_to_world(self, cells) -> np.ndarray:
        """(..., 2) [row, col] -> (..., 2) world xy of the cell centres."""
        cells = np.asarray(cells, dtype=float)
        x = self.origin[0] + (cells[..., 1] + 0.5) * self.resolution
        y = self.origin[1] + (cells[..., 0] + 0.5) * self.resolution
        return np.stack([x, y], axis=-1)

    def in_grid(self, cells) -> np.ndarray:
        cells = np.asarray(cells)
        return ((cells[..., 0] >= 0) & (cells[..., 0] < self.shape[0])
                & (cells[..., 1] >= 0) & (cells[..., 1] < self.shape[1]))

    def is_free(self, xy) -> np.ndarray | bool:
        """Free-space test for one point (bool) or an (N, 2) array (bool array)."""
        cells = self.world_to_cell(xy)
        inside = self.in_grid(cells)
        rows, cols = np.where(inside, cells[..., 0], 0), np.where(inside, cells[..., 1], 0)
        out = inside & self.free[rows, cols]
        return bool(out) if out.ndim == 0 else out

    def clearance_grid(self) -> np.ndarray:
        """Metres from each cell centre to the nearest blocked cell centre (0 on blocked cells)."""
        if self._clearance is None:
            self._clearance = ndimage.distance_transform_edt(self.free) * self.resolution
        return self._clearance

    def eroded(self, radius: float) -> "TraversabilityMap":
        """Cells whose clearance exceeds `radius` (cached per radius)."""
        key = round(float(radius), 4)
        if key not in self._eroded:
            self._eroded[key] = TraversabilityMap(self.clearance_grid() > radius, self.origin, self.resolution)
        return self._eroded[key]

    def coarsened(self, factor: int) -> "TraversabilityMap":
        """Map at `factor` x the resolution; a coarse cell is free only if all its cells are."""
        if factor == 1:
            return self
        if factor not in self._coarse:
            rows, cols = (-(-n // factor) * factor for n in self.shape)
            padded = np.zeros((rows, cols), dtype=bool)
            padded[:self.shape[0], :self.shape[1]] = self.free
            blocks = padded.reshape(rows // factor, factor, cols // factor, factor).all(axis=(1, 3))
            self._coarse[factor] = TraversabilityMap(blocks, self.origin, self.resolution * factor)
        return self._coarse[factor]

    def component_labels(self) -> np.ndarray:
        """8-connected component label per free cell (0 = blocked)."""
        if self._labels is None:
            self._labels, _ = ndimage.label(self.free, structure=np.ones((3, 3)))
        return self._labels

    def largest_component(self) -> np.ndarray:
        labels = self.component_labels()
        counts = np.bincount(labels.ravel())
        counts[0] = 0
        return labels == int(np.argmax(counts))

    def nearest_in_component(self, label: int) -> tuple[np.ndarray, np.ndarray]:
        """For every cell: (metres to the nearest cell of component `label`, its flat index)."""
        if label not in self._fill:
            outside = self.component_labels() != label
            dist, idx = ndimage.distance_transform_edt(outside, return_indices=True)
            flat = np.ravel_multi_index((idx[0], idx[1]), self.shape)
            self._fill[label] = (dist * self.resolution, flat)
        return self._fill[label]


class GeodesicField:
    """Shortest-path distance to one goal over the map eroded by `robot_radius`.

    The field is solved at `resolution` (default 0.1 m: fast marching costs ~0.4 us per
    cell, so 0.05 m would take ~40 ms per goal); the eroded 0.05 m map is coarsened so a
    coarse cell is free only if all its fine cells are. Points off the eroded free space
    (e.g. a robot pushed against a wall) get the distance of the nearest reachable cell
    plus the straight offset when that offset is at most `snap_radius`, else inf. A goal
    off the free space is snapped the same way (`goal_snapped_xy`); an unsnappable goal
    makes every distance inf.
    """

    def __init__(self, trav_map: TraversabilityMap, goal_xy, robot_radius: float = ROBOT_RADIUS,
                 snap_radius: float = 0.5, resolution: float = FIELD_RESOLUTION):
        eroded = trav_map.eroded(robot_radius)
        self.map = eroded.coarsened(max(int(round(resolution / eroded.resolution)), 1))
        self.goal_xy = np.asarray(goal_xy, dtype=float)[:2].copy()
        self.robot_radius = robot_radius
        self.snap_radius = snap_radius
        self.field = self._solve()
        self._gx: np.ndarray | None = None
        self._gy: np.ndarray | None = None

    def _goal_component(self):
        """Component label and snapped goal point, or (0, None) when the goal is unreachable."""
        m = self.map
        labels = m.component_labels()
        cell = m.world_to_cell(self.goal_xy)
        if m.in_grid(cell) and labels[cell[0], cell[1]] > 0:
            return int(labels[cell[0], cell[1]]), self.goal_xy
        seeds = np.flatnonzero(labels.ravel() > 0)
        if len(seeds) == 0:
            return 0, None
        centres = m.cell_to_world(np.stack(np.unravel_index(seeds, m.shape), axis=-1))
        k = int(np.argmin(np.linalg.norm(centres - self.goal_xy, axis=1)))
        if np.linalg.norm(centres[k] - self.goal_xy) > self.snap_radius:
            return 0, None
        return int(labels.ravel()[seeds[k]]), centres[k]

    def _solve(self) -> np.ndarray:
        m, res = self.map, self.map.resolution
        label, snapped = self._goal_component()
        self.goal_snapped_xy = snapped
        if label == 0:
            return np.full(m.shape, np.inf)
        offset = float(np.linalg.norm(snapped - self.goal_xy))
        reachable = m.component_labels() == label
        xs = m.origin[0] + (np.arange(m.shape[1]) + 0.5) * res
        ys = m.origin[1] + (np.arange(m.shape[0]) + 0.5) * res
        r0 = 2 * res  # zero contour: a circle around the goal (1 cell is too coarse for skfmm)
        phi = np.hypot(xs[None, :] - snapped[0], ys[:, None] - snapped[1]) - r0
        dist = skfmm.distance(np.ma.MaskedArray(phi, ~reachable), dx=res)
        field = np.where(reachable, np.ma.filled(dist, np.inf) + r0, np.inf)
        field = np.maximum(field, 0.0) + offset
        snap_dist, nearest = m.nearest_in_component(label)
        filled = field.ravel()[nearest].reshape(m.shape) + snap_dist
        return np.where(reachable, field, np.where(snap_dist <= self.snap_radius, filled, np.inf))

    def _ensure_gradients(self) -> None:
        if self._gx is None:
            finite = np.isfinite(self.field)
            cap = (self.field[finite].max() if finite.any() else 0.0) + 1.0
            self._gy, self._gx = np.gradient(np.where(finite, self.field, cap), self.map.resolution)

    def _bilinear(self, grid: np.ndarray, x: float, y: float) -> float:
        """Interpolate `grid` at (x, y), ignoring inf corners (scalar code: called per step)."""
        m = self.map
        rows, cols = m.shape
        fx = min(max((x - m.origin[0]) / m.resolution - 0.5, 0.0), cols - 1.000001)
        fy = min(max((y - m.origin[1]) / m.resolution - 0.5, 0.0), rows - 1.000001)
        j, i = int(fx), int(fy)
        tx, ty = fx - j, fy - i
        total = weight = 0.0
        for di, dj, w in ((0, 0, (1 - tx) * (1 - ty)), (0, 1, tx * (1 - ty)), (1, 0, (1 - tx) * ty),
                          (1, 1, tx * ty)):
            v = grid.item(i + di, j + dj)
            if v != math.inf:
                total += w * v
                weight += w
        return total / weight if weight > 1e-9 else math.inf

    def distance(self, xy) -> float:
        """Geodesic distance in metres from `xy` to the goal (inf if unreachable)."""
        return self._bilinear(self.field, float(xy[0]), float(xy[1]))

    path_length = distance

    def distances(self, xy) -> np.ndarray:
        """Vectorised `distance` for an (N, 2) array (same bilinear rule)."""
        m = self.map
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        fx = np.clip((xy[:, 0] - m.origin[0]) / m.resolution - 0.5, 0.0, m.shape[1] - 1.000001)
        fy = np.clip((xy[:, 1] - m.origin[1]) / m.resolution - 0.5, 0.0, m.shape[0] - 1.000001)
        j, i = fx.astype(int), fy.astype(int)
        tx, ty = fx - j, fy - i
        total, weight = np.zeros(len(xy)), np.zeros(len(xy))
        for di, dj, w in ((0, 0, (1 - tx) * (1 - ty)), (0, 1, tx * (1 - ty)), (1, 0, (1 - tx) * ty),
                          (1, 1, tx * ty)):
            v = self.field[i + di, j + dj]
            ok = np.isfinite(v)
            total += np.where(ok, w * np.where(ok, v, 0.0), 0.0)
            weight += np.where(ok, w, 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(weight > 1e-9, total / weight, np.inf)

    def _gradient(self, x: float, y: float) -> tuple[float, float]:
        """Bilinear field gradient at (x, y) (gradient grids hold no inf)."""
        m = self.map
        fx = min(max((x - m.origin[0]) / m.resolution - 0.5, 0.0), m.shape[1] - 1.000001)
        fy = min(max((y - m.origin[1]) / m.resolution - 0.5, 0.0), m.shape[0] - 1.000001)
        j, i = int(fx), int(fy)
        tx, ty = fx - j, fy - i
        gx, gy = self._gx, self._gy
        ax = (1 - tx) * gx.item(i, j) + tx * gx.item(i, j + 1)
        bx = (1 - tx) * gx.item(i + 1, j) + tx * gx.item(i + 1, j + 1)
        ay = (1 - tx) * gy.item(i, j) + tx * gy.item(i, j + 1)
        by = (1 - tx) * gy.item(i + 1, j) + tx * gy.item(i + 1, j + 1)
        return (1 - ty) * ax + ty * bx, (1 - ty) * ay + ty * by

    def _descent_direction(self, x: float, y: float) -> tuple[float, float] | None:
        gx, gy = self._gradient(x, y)
        norm = math.hypot(gx, gy)
        if norm > 0.3:
            return -gx / norm, -gy / norm
        return self._best_neighbour_direction(x, y)

    def _best_neighbour_direction(self, x: float, y: float) -> tuple[float, float] | None:
        """Fallback on flat/ridge spots: head for the lowest of the 8 neighbouring cells."""
        m = self.map
        j = min(max(int((x - m.origin[0]) / m.resolution), 0), m.shape[1] - 1)
        i = min(max(int((y - m.origin[1]) / m.resolution), 0), m.shape[0] - 1)
        best, here = None, self.field.item(i, j)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                ii, jj = i + di, j + dj
                if (di or dj) and 0 <= ii < m.shape[0] and 0 <= jj < m.shape[1]:
                    v = self.field.item(ii, jj)
                    if v < here:
                        here, best = v, (dj, di)
        if best is None:
            return None
        n = math.hypot(*best)
        return best[0] / n, best[1] / n

    def waypoints(self, xy, n: int = 10, spacing: float = 0.2) -> np.ndarray:
        """Next `n` points on the shortest path from `xy`, `spacing` metres apart along it.

        The first point is `spacing` metres from `xy` (not `xy` itself). Points beyond the
        goal (and all points if the path cannot be followed) are the goal itself.
        """
        out = np.tile(self.goal_xy, (n, 1))
        if self.distance(xy) == math.inf:
            return out
        self._ensure_gradients()
        h = min(0.5 * self.map.resolution, spacing)
        x, y = float(xy[0]), float(xy[1])
        gx, gy = float(self.goal_snapped_xy[0]), float(self.goal_snapped_xy[1])
        travelled, k = 0.0, 0
        for _ in range(int(4 * n * spacing / h) + 10):
            if (x - gx) ** 2 + (y - gy) ** 2 <= h * h:
                break
            d = self._descent_direction(x, y)
            if d is None:
                break
            step = min(h, spacing - travelled)
            x, y = x + step * d[0], y + step * d[1]
            travelled += step
            if travelled >= spacing - 1e-9:
                out[k] = (x, y)
                k, travelled = k + 1, 0.0
                if k == n:
                    break
        return out


@dataclass
class StartGoal:
    start_xy: np.ndarray
    start_yaw: float
    goal_xy: np.ndarray
    geodesic_distance: float
    field: GeodesicField


def _candidate_cells(trav_map: TraversabilityMap, region: Rect | None, clearance: float) -> np.ndarray:
    """Flat indices of cells in `region` on the largest component of the map eroded by `clearance`."""
    key = (region, round(clearance, 4))
    if key not in trav_map._candidates:
        mask = trav_map.eroded(clearance).largest_component()
        if region is not None:
            rows, cols = trav_map._cell_slice(region)
            inside = np.zeros_like(mask)
            inside[rows, cols] = True
            mask = mask & inside
        trav_map._candidates[key] = np.flatnonzero(mask)
    return trav_map._candidates[key]


def _cell_centres(trav_map: TraversabilityMap, flat: np.ndarray) -> np.ndarray:
    return trav_map.cell_to_world(np.stack(np.unravel_index(flat, trav_map.shape), axis=-1))


def sample_free_point(trav_map: TraversabilityMap, rng: np.random.Generator, region: Rect | None = None,
                      clearance: float = ROBOT_RADIUS + FREE_POINT_MARGIN) -> np.ndarray:
    """A cell centre with at least `clearance` to obstacles, on the main free component."""
    cells = _candidate_cells(trav_map, region, clearance)
    if len(cells) == 0:
        raise ValueError(f"no free cell with clearance {clearance} in {region}")
    return _cell_centres(trav_map, cells[rng.integers(len(cells))])


def sample_start_goal(trav_map: TraversabilityMap, rng: np.random.Generator, min_geodesic: float = 1.0,
                      max_geodesic: float = 10.0, start_region: Rect | None = None,
                      goal_region: Rect | None = None, robot_radius: float = ROBOT_RADIUS,
                      clearance: float = ROBOT_RADIUS + FREE_POINT_MARGIN, max_tries: int = 50) -> StartGoal:
    """Sample a goal, solve its field once, then a start whose geodesic distance is in range.

    Starts are drawn in batches of 256 candidate cells (cheaper than scoring every cell);
    a goal with no in-range start among 4 batches is resampled.
    """
    starts = _candidate_cells(trav_map, start_region, clearance)
    if len(starts) == 0:
        raise ValueError(f"no free cell with clearance {clearance} in {start_region}")
    for _ in range(max_tries):
        goal = sample_free_point(trav_map, rng, goal_region, clearance)
        field = GeodesicField(trav_map, goal, robot_radius)
        for _ in range(4):
            xy = _cell_centres(trav_map, starts[rng.integers(len(starts), size=256)])
            d = field.distances(xy)
            ok = np.flatnonzero((d >= min_geodesic) & (d <= max_geodesic))
            if len(ok):
                k = ok[0]
                yaw = float(rng.uniform(-math.pi, math.pi))
                return StartGoal(xy[k], yaw, goal, float(d[k]), field)
    raise RuntimeError(f"no start/goal pair with geodesic distance in [{min_geodesic}, {max_geodesic}]")
