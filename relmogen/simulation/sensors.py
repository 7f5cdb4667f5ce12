"""RGB-D camera and planar LiDAR on PyBullet's CPU renderer and batched ray tests.

Camera conventions
    The camera link looks along its +x axis with +z up (URDF convention). Images are
    row-major ``(H, W)``; pixel ``(u, v)`` is column ``u``, row ``v``. Depth is the distance
    along the optical axis in metres (float32). Pixels nearer than ``min_depth`` or farther
    than ``max_depth`` have no valid return and read ``0.0`` (as real RGB-D sensors report
    them); ``CameraIntrinsics.deproject`` refuses them. That clipped depth is the observation.
    The 3D point behind a pixel (an arm subgoal, the arm mask) comes from ``point_depth``, the
    renderer's depth without the sensor's range, as the original's arm subgoal came from
    iGibson's unclipped ``3d`` render: a door 0.3 m in front of the robot still has points.

LiDAR conventions
    ``num_rays`` rays evenly spread over ``fov`` centred on the LiDAR link's +x axis, in the
    horizontal plane of the robot base. Ranges are metres, clipped to ``max_range``; a ray
    that hits nothing reads ``max_range``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p

INVALID_DEPTH = 0.0
_NEAR_PLANE = 0.05
_FAR_PLANE = 10.0
# Eye shifts (camera frame: forward, left, up; metres) tried in turn when TinyRenderer returns an
# all-NaN z-buffer (and a black image) for a rare exact pose.
_EYE_SHIFTS = ((0.0, 0.0, 0.0), (0.0, 0.0, 1e-3), (0.0, 0.0, 1e-2), (0.0, 1e-2, 0.0), (-1e-2, 0.0, 0.0))


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole model of a square-pixel camera; ``fx = fy``, principal point at the centre."""

    width: int
    height: int
    fov_deg: float  # vertical field of view

    @property
    def fy(self) -> float:
        return 0.5 * self.height / np.tan(np.deg2rad(self.fov_deg) / 2.0)

    @property
    def fx(self) -> float:
        return self.fy

    @property
    def cx(self) -> float:
        return 0.5 * self.width

    @property
    def cy(self) -> float:
        return 0.5 * self.height

    @property
    def matrix(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def deproject(self, u: float, v: float, depth: float) -> np.ndarray:
        """Pixel centre ``(u, v)`` at optical depth ``depth`` -> point in the camera link frame."""
        if not np.isfinite(depth) or depth <= INVALID_DEPTH:
            raise ValueError(f"pixel ({u}, {v}) has no valid depth ({depth})")
        return self.deproject_many(np.asarray(u), np.asarray(v), np.asarray(depth, dtype=np.float64))

    def deproject_many(self, us: np.ndarray, vs: np.ndarray, depths: np.ndarray) -> np.ndarray:
        """Arrays of pixel centres and depths (shape S) -> S + (3,) camera-frame points, unchecked."""
        right = (us + 0.5 - self.cx) / self.fx * depths
        down = (vs + 0.5 - self.cy) / self.fy * depths
        return np.stack([depths, -right, -down], axis=-1)

    def project(self, point_camera: np.ndarray) -> tuple[float, float, float]:
        """Point in the camera link frame -> continuous pixel ``(u, v)`` and depth."""
        forward, left, up = np.asarray(point_camera, dtype=np.float64)
        u = self.cx + (-left / forward) * self.fx - 0.5
        v = self.cy + (-up / forward) * self.fy - 0.5
        return float(u), float(v), float(forward)


@dataclass(frozen=True)
class CameraFrame:
    rgb: np.ndarray  # (H, W, 3) uint8
    depth: np.ndarray  # (H, W) float32 metres, INVALID_DEPTH where out of the sensor's range
    position: np.ndarray  # camera origin in the world
    rotation: np.ndarray  # 3x3 camera link -> world
    # (H, W) float32 metres, INVALID_DEPTH only where the ray hits nothing; None: same as depth
    point_depth: np.ndarray | None = None

    @property
    def points_depth(self) -> np.ndarray:
        """The depth the pixels' 3D points are taken from (``point_depth``, else ``depth``)."""
        return self.depth if self.point_depth is None else self.point_depth

    def has_point(self, row: int, col: int) -> bool:
        """Whether pixel (row, col) sees a surface, so that it has a 3D point."""
        return bool(self.points_depth[row, col] > INVALID_DEPTH)


class Camera:
    """Renders RGB-D images from a pose with PyBullet's TinyRenderer (CPU, no GL)."""

    def __init__(self, client: int, width: int = 128, height: int = 128, fov_deg: float = 90.0,
                 min_depth: float = 0.35, max_depth: float = 3.0):
        if width <= 0 or height <= 0:
            raise ValueError(f"camera resolution must be positive, got {width}x{height}")
        self.client = client
        self.intrinsics = CameraIntrinsics(width, height, fov_deg)
        self.min_depth, self.max_depth = min_depth, max_depth
        self.blind_frames = 0
        self._projection = p.computeProjectionMatrixFOV(
            fov=fov_deg, aspect=width / height, nearVal=_NEAR_PLANE, farVal=_FAR_PLANE
        )

    def capture(self, position: np.ndarray, rotation: np.ndarray) -> CameraFrame:
        """RGB-D from ``position`` looking along ``rotation``'s x axis. Pixels the renderer leaves
        NaN at every eye shift read as no return; when every shift leaves the whole image NaN
        (seen once in a PointNav training run, where it killed the run), the frame is blind: black,
        with no return anywhere, and ``blind_frames`` counts it."""
        position = np.asarray(position, dtype=np.float64)
        best, best_nan = None, None
        for shift in _EYE_SHIFTS:
            rgba, zbuffer = self._render(position + np.asarray(rotation) @ np.asarray(shift), rotation)
            nan = np.isnan(zbuffer)
            if not nan.any():
                return self._frame(rgba, zbuffer, nan, position, rotation)
            if not nan.all() and (best is None or nan.sum() < best_nan.sum()):
                best, best_nan = (rgba, zbuffer), nan
        if best is None:
            self.blind_frames += 1
            height, width = self.intrinsics.height, self.intrinsics.width
            return CameraFrame(np.zeros((height, width, 3), np.uint8), np.full((height, width), INVALID_DEPTH,
                                                                             np.float32), position, np.asarray(rotation))
        return self._frame(*best, best_nan, position, rotation)

    def _frame(self, rgba: np.ndarray, zbuffer: np.ndarray, nan: np.ndarray, position: np.ndarray,
               rotation: np.ndarray) -> CameraFrame:
        point_depth = self._linearise(np.nan_to_num(zbuffer, nan=1.0))
        point_depth[nan.reshape(point_depth.shape) | (point_depth >= _FAR_PLANE * 0.999)] = INVALID_DEPTH
        depth = point_depth.copy()
        depth[(depth < self.min_depth) | (depth > self.max_depth)] = INVALID_DEPTH
        return CameraFrame(rgba[..., :3], depth, position, np.asarray(rotation), point_depth)

    def _render(self, eye: np.ndarray, rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        view = p.computeViewMatrix(eye, eye + rotation[:, 0], rotation[:, 2])
        _, _, rgba, zbuffer, _ = p.getCameraImage(
            self.intrinsics.width, self.intrinsics.height, view, self._projection,
            renderer=p.ER_TINY_RENDERER, flags=p.ER_NO_SEGMENTATION_MASK,
            physicsClientId=self.client,
        )
        rgba = np.asarray(rgba, dtype=np.uint8).reshape(self.intrinsics.height, self.intrinsics.width, 4)
        return rgba, np.asarray(zbuffer, dtype=np.float32)

    def _linearise(self, zbuffer: np.ndarray) -> np.ndarray:
        depth = _FAR_PLANE * _NEAR_PLANE / (_FAR_PLANE - (_FAR_PLANE - _NEAR_PLANE) * zbuffer)
        return depth.reshape(self.intrinsics.height, self.intrinsics.width).astype(np.float32)

    def pixel_to_world(self, frame: CameraFrame, u: int, v: int) -> np.ndarray:
        """The world point seen at pixel ``(u, v)`` of ``frame``; ValueError if it has no depth."""
        h, w = frame.depth.shape
        if not (0 <= u < w and 0 <= v < h):
            raise ValueError(f"pixel ({u}, {v}) outside the {w}x{h} image")
        local = self.intrinsics.deproject(u, v, float(frame.points_depth[v, u]))
        return frame.position + frame.rotation @ local

    def pixels_to_world(self, frame: CameraFrame, us: np.ndarray, vs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World points seen at integer pixel arrays ``us``, ``vs`` (same shape S) -> (S + (3,)) points
        and an S bool array of pixels with depth (points there are NaN)."""
        depth = frame.points_depth[vs, us].astype(np.float64)
        valid = depth > INVALID_DEPTH
        local = self.intrinsics.deproject_many(us, vs, np.where(valid, depth, np.nan))
        return frame.position + local @ frame.rotation.T, valid

    def surface_normals(self, frame: CameraFrame, us: np.ndarray, vs: np.ndarray, offset: int = 1) -> np.ndarray:
        """Unit world normals (S + (3,)) of the surfaces seen at pixels ``us``, ``vs``, facing the
        camera: the cross product of one step along each image axis to the point ``offset``
        pixels away. Of the two sides of an axis, the step is taken on the side that continues
        straight for a second step, so that a pixel next to an edge keeps its own surface.
        NaN where the pixel or its neighbours lack depth."""
        h, w = frame.depth.shape

        def seen(du: int, dv: int) -> np.ndarray:
            return self.pixels_to_world(frame, np.clip(us + du, 0, w - 1), np.clip(vs + dv, 0, h - 1))[0]

        centre = seen(0, 0)

        def straighter_step(du: int, dv: int) -> np.ndarray:
            steps, bends = [], []
            for side in (1, -1):
                first = seen(side * du, side * dv) - centre
                second = seen(2 * side * du, 2 * side * dv) - centre - first
                steps.append(side * first)
                bends.append(np.nan_to_num(np.linalg.norm(_unit(second) - _unit(first), axis=-1), nan=np.inf))
            return np.where((bends[0] <= bends[1])[..., None], steps[0], steps[1])

        normals = _unit(np.cross(straighter_step(offset, 0), straighter_step(0, offset)))
        away = np.sum(normals * (centre - frame.position), axis=-1) > 0
        return np.where(away[..., None], -normals, normals)


def _unit(vectors: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return vectors / np.linalg.norm(vectors, axis=-1, keepdims=True)


class Lidar:
    """A single-plane scanner evaluated with one ``rayTestBatch`` call."""

    def __init__(self, client: int, num_rays: int = 220, fov_deg: float = 220.0,
                 max_range: float = 25.0, min_range: float = 0.05):
        if num_rays < 2:
            raise ValueError(f"a LiDAR needs at least 2 rays, got {num_rays}")
        self.client = client
        self.num_rays, self.max_range, self.min_range = num_rays, max_range, min_range
        half = np.deg2rad(fov_deg) / 2.0
        self.angles = np.linspace(-half, half, num_rays)
        self._unit = np.stack([np.cos(self.angles), np.sin(self.angles), np.zeros(num_rays)], axis=1)

    def scan(self, position: np.ndarray, yaw: float) -> np.ndarray:
        """Ranges (float32, metres) from ``position`` with the scan centred on heading ``yaw``."""
        c, s = np.cos(yaw), np.sin(yaw)
        rotation = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        dirs = self._unit @ rotation.T
        starts = position + self.min_range * dirs
        ends = position + self.max_range * dirs
        hits = p.rayTestBatch(starts.tolist(), ends.tolist(), physicsClientId=self.client)
        fractions = np.fromiter((h[2] for h in hits), dtype=np.float64, count=self.num_rays)
        ranges = self.min_range + fractions * (self.max_range - self.min_range)
        return ranges.astype(np.float32)
