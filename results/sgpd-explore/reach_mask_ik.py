"""How many arm cells the sphere reach mask allows have no IK solution, and which of them the
measured reachability map (``env.reach_mask=measured``) keeps: TASK EPISODES.

In each episode (seeds 100000+): the start state and the states after two random base subgoals;
in each, 40 random cells the sphere mask allows, solved by the arm's IK as it runs (100
iterations, 50 attempts, 5 cm), collisions ignored. Prints the counts of (in the map, IK solved)
and IK success by horizontal distance from the base.

    python results/sgpd-explore/reach_mask_ik.py ArrangeKitchenMM 8
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

import numpy as np

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import YAW_BINS
from relmogen.experiments.config import resolve_config
from relmogen.experiments.train import env_kwargs
from relmogen.robots.reachability import load_reachability

CELLS_PER_STATE = 40


def sampled_cells(env, reach, info, rng) -> list[tuple[float, float, bool, bool]]:
    """(horizontal distance, height, in the map, IK solved) of random sphere-allowed cells."""
    control, pose = env.control, env.robot.base_pose()
    cells = np.argwhere(info["arm_mask"])
    rows = []
    for i, j in cells[rng.permutation(len(cells))[:CELLS_PER_STATE]]:
        row, col = control.cell_pixel(i, j)
        point = env.camera.pixels_to_world(env.last_frame, np.array([col]), np.array([row]))[0][0]
        solved = control.mg.arm.ik_solver.solve(point, rng, 100, 50, 0.05).config is not None
        rows.append((float(np.linalg.norm(point[:2] - pose[:2])), float(point[2]),
                     bool(reach.contains_world(point, pose)), solved))
    return rows


def random_base_action(control, info, rng) -> int:
    i, j = np.argwhere(info["base_mask"])[rng.integers(info["base_mask"].sum())]
    return int(np.ravel_multi_index((rng.integers(YAW_BINS), i, j), (YAW_BINS, control.q, control.q)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("task")
    parser.add_argument("episodes", type=int)
    args = parser.parse_args()
    config = resolve_config(args.task, "relmogen-d", overrides=["env.push_frame=surface"])
    env, rng, rows, start = RelmogenEnv(**env_kwargs(config, arm_collision=False)), np.random.default_rng(0), [], time.process_time()
    reach = load_reachability(env.robot.spec)
    for episode in range(args.episodes):
        _, info = env.reset(seed=100_000 + episode)
        for _ in range(3):
            rows += sampled_cells(env, reach, info, rng)
            _, _, _, _, info = env.step(random_base_action(env.control, info, rng))
    env.close()
    counts = Counter((in_map, solved) for _, _, in_map, solved in rows)
    print(f"{len(rows)} cells, IK solved {np.mean([r[3] for r in rows]):.3f}; (in map, solved): {dict(counts)}; "
          f"{time.process_time() - start:.0f} CPU s")
    table = np.array(rows)
    for low in np.arange(0.0, 1.4, 0.2):
        band = (table[:, 0] >= low) & (table[:, 0] < low + 0.2)
        if band.any():
            print(f"{low:.1f}-{low + 0.2:.1f} m: {band.sum()} cells, IK solved {table[band, 3].mean():.2f}")


if __name__ == "__main__":
    main()
