"""Measured arm reachability: which points around the base the gripper can reach.

A robot's ``spec.arm_reach`` is a sphere around the first arm joint: no plan is ever found
beyond it, but some points inside it have no IK solution either (with Fetch, 15% of the arm
cells SGP-D allowed in ArrangeKitchenMM, most of them 1.0-1.4 m from the base).
The reachability map is a voxel grid in the base frame (x forward, y left, z up from the floor)
of the points within the IK tolerance of a gripper position some configuration of the planning
joints (torso and arm, within their limits) reaches: forward kinematics of random
configurations, as in capability maps (Zacharias et al. 2007), dilated by the tolerance.
Collisions are ignored, so the map is a superset of where a collision-free solution exists.

The map is data beside the robot: ``assets/<name>/reachability.npz``, written by

    python -m relmogen.robots.reachability fetch [--samples 3000000]
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from relmogen.robots.spec import ASSETS_DIR, EmbodimentSpec, load_spec

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
                                f"write it with: python -m relmogen.robots.reachability {spec.name}")
    return ReachabilityMap.load(path)


def gripper_positions(spec: EmbodimentSpec, samples: int, seed: int) -> np.ndarray:
    """Gripper positions (base frame) of ``samples`` uniform random torso + arm configurations."""
    from relmogen.motion_generation.ik import ArmIK  # the motion stack imports robots, not the reverse
    from relmogen.robots.robot import Robot
    from relmogen.simulation.world import World

    world = World()
    try:
        robot = Robot(world.client, spec)
        ik, rng = ArmIK(world.client, robot), np.random.default_rng(seed)
        positions = np.array([ik.end_effector_at(ik.random_config(rng)) for _ in range(samples)])
        return world_to_base(positions, robot.base_pose())
    finally:
        world.close()


def measure_reachability(spec: EmbodimentSpec, samples: int = 3_000_000, seed: int = 0,
                         voxel: float = VOXEL_M, tolerance: float | None = None) -> ReachabilityMap:
    """Voxelise sampled gripper positions, then dilate by ``tolerance`` (a ball; default the
    arm's IK tolerance: a point that close to a reachable position is solved)."""
    if tolerance is None:
        from relmogen.motion_generation.arm import ArmConfig
        tolerance = ArmConfig.ik_tolerance
    positions = gripper_positions(spec, samples, seed)
    margin = tolerance + 2 * voxel
    origin = positions.min(axis=0) - margin
    shape = np.ceil((positions.max(axis=0) + margin - origin) / voxel).astype(int)
    hit = np.zeros(shape, dtype=bool)
    index = np.floor((positions - origin) / voxel).astype(int)
    hit[index[:, 0], index[:, 1], index[:, 2]] = True
    radius = int(np.ceil(tolerance / voxel))
    offsets = np.arange(-radius, radius + 1)
    ball = np.sum(np.stack(np.meshgrid(offsets, offsets, offsets, indexing="ij")) ** 2, axis=0) * voxel**2 <= tolerance**2
    return ReachabilityMap(origin, voxel, ndimage.binary_dilation(hit, structure=ball))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Measure a robot's arm reachability map and save it beside its spec.")
    parser.add_argument("robot", help=f"a folder of {ASSETS_DIR}")
    parser.add_argument("--samples", type=int, default=3_000_000, help="random configurations (default 3e6)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.samples <= 0:
        parser.error("--samples must be positive")
    spec = load_spec(args.robot)
    reach = measure_reachability(spec, args.samples, args.seed)
    reach.save(map_path(spec), args.samples)
    print(f"{map_path(spec)}: {reach.reachable.sum()} of {reach.reachable.size} voxels of {reach.voxel} m reachable "
          f"({reach.reachable.sum() * reach.voxel**3:.2f} m^3) from {args.samples} configurations")


if __name__ == "__main__":
    main()
