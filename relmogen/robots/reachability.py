"""Measured arm reachability: which points around the base the gripper can reach.

A robot's ``spec.arm_reach`` is a sphere around the first arm joint: no plan is ever found
beyond it, but some points inside it have no IK solution either (with Fetch, 15% of the arm
cells SGP-D allowed in ArrangeKitchenMM, most of them 1.0-1.4 m from the base).
The reachability map is a voxel grid in the base frame (x forward, y left, z up from the floor)
of the points within the IK tolerance of a gripper position some configuration of the planning
joints (torso and arm, within their limits) reaches: forward kinematics of random
configurations, as in capability maps (Zacharias et al. 2007), dilated by the tolerance.
Collisions are ignored, so the map is a superset of where a collision-free solution exists.

The map is data beside the robot: ``assets/<name>/reachability.npz``, measured with the robot's
IK by ``relmogen.motion_generation.reachability``:

    python -m relmogen.motion_generation.reachability fetch [--samples 3000000]
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from relmogen.robots.spec import EmbodimentSpec

MAP_FILE = "reachability.npz"
VOXEL_M = 0.025


@dataclass(frozen=True)
class ReachabilityMap:
    """Boolean voxels ``reachable[i, j, k]`` covering ``origin + (i, j, k) * voxel`` (base frame)."""

    origin: np.ndarray
    voxel: float
    reachable: np.ndarray

    def contains(self, points_base: np.ndarray) -> np.ndarray:
        """Which base-frame points ``(..., 3)`` lie in a reachable voxel (NaN points do not)."""
        points = np.asarray(points_base, dtype=np.float64)
        index = np.floor((np.nan_to_num(points, nan=-1e9) - self.origin) / self.voxel).astype(np.int64)
        inside = np.all((index >= 0) & (index < self.reachable.shape), axis=-1)
        clipped = np.clip(index, 0, np.array(self.reachable.shape) - 1)
        return inside & self.reachable[clipped[..., 0], clipped[..., 1], clipped[..., 2]]

    def contains_world(self, points_world: np.ndarray, base_pose: np.ndarray) -> np.ndarray:
        """``contains`` for world points, the base at ``(x, y, yaw)`` on the floor."""
        return self.contains(world_to_base(points_world, base_pose))

    def save(self, path: Path, samples: int) -> None:
        np.savez_compressed(path, origin=self.origin, voxel=self.voxel, samples=samples,
                            shape=np.array(self.reachable.shape), bits=np.packbits(self.reachable.ravel()))

    @classmethod
    def load(cls, path: Path) -> ReachabilityMap:
        with np.load(path) as data:
            shape = tuple(int(n) for n in data["shape"])
            reachable = np.unpackbits(data["bits"])[: int(np.prod(shape))].reshape(shape).astype(bool)
            return cls(np.asarray(data["origin"], dtype=np.float64), float(data["voxel"]), reachable)


def world_to_base(points_world: np.ndarray, base_pose: np.ndarray) -> np.ndarray:
    """World points ``(..., 3)`` in the frame of a base at ``(x, y, yaw)`` (z unchanged)."""
    points = np.asarray(points_world, dtype=np.float64)
    x, y, yaw = (float(v) for v in base_pose)
    dx, dy = points[..., 0] - x, points[..., 1] - y
    cos, sin = np.cos(yaw), np.sin(yaw)
    return np.stack([cos * dx + sin * dy, -sin * dx + cos * dy, points[..., 2]], axis=-1)


def map_path(spec: EmbodimentSpec) -> Path:
    return spec.spec_dir / MAP_FILE


def load_reachability(spec: EmbodimentSpec) -> ReachabilityMap:
    """The robot's measured map; a clear error naming the command when it was never measured."""
    path = map_path(spec)
    if not path.is_file():
        raise FileNotFoundError(f"robot {spec.name!r} has no measured reachability map ({path}); "
                                f"write it with: python -m relmogen.motion_generation.reachability {spec.name}")
    return ReachabilityMap.load(path)
