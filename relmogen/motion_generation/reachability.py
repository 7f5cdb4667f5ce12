"""Measuring a robot's arm reachability map (``relmogen.robots.reachability``) with its IK.

Forward kinematics of random torso + arm configurations (``ArmIK``), as in capability maps
(Zacharias et al. 2007), voxelised and dilated by the arm's IK tolerance; saved beside the
robot's spec by

    python -m relmogen.motion_generation.reachability fetch [--samples 3000000]
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy import ndimage

from relmogen.motion_generation.arm import ArmConfig
from relmogen.motion_generation.ik import ArmIK
from relmogen.robots.reachability import VOXEL_M, ReachabilityMap, map_path, world_to_base
from relmogen.robots.robot import Robot
from relmogen.robots.spec import ASSETS_DIR, EmbodimentSpec, load_spec
from relmogen.simulation.world import World


def gripper_positions(spec: EmbodimentSpec, samples: int, seed: int) -> np.ndarray:
    """Gripper positions (base frame) of ``samples`` uniform random torso + arm configurations."""
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
