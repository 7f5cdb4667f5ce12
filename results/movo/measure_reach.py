"""How far from the first arm joint does the arm planner reach? Fetch against Movo, the same way.

For each robot and task: episodes with seeds 2000.., and in each reset state ``PER_STATE``
random camera pixels with depth (world state restored before each). Each pixel's point is
handed to the motion generator's arm (``reach_and_push``: IK, collision checking on, joint-space
RRT-Connect, no push) with the spec's ``arm_reach`` mask lifted; the plan-found share is counted
per band of distance from ``robot.arm_base_position()``. Prints a table and writes
``reach_<robot>.json``.

    python results/movo/measure_reach.py --out results/movo
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from relmogen.envs.relmogen_env import RelmogenEnv

BANDS = ((0.0, 0.6), (0.6, 0.8), (0.8, 1.0), (1.0, 1.2), (1.2, 1.3), (1.3, 1.4), (1.4, 1.6), (1.6, math.inf))
TASKS = ("TabletopReachM", "PushDoorNav", "ArrangeKitchenMM")
EPISODES, PER_STATE = 4, 20


def samples(robot: str, task: str) -> list[dict]:
    env = RelmogenEnv(task=task, control="subgoal-r", robot=robot, image_size=64, arm_collision=True)
    env.robot.spec = dataclasses.replace(env.robot.spec, arm_reach=10.0)  # no mask: measure it
    rng, out = np.random.default_rng(0), []
    for episode in range(EPISODES):
        env.reset(seed=2000 + episode)
        state = env.world.save_state()
        for _ in range(PER_STATE):
            env.world.restore_state(state)
            env._observe()
            frame = env.last_frame
            rows, cols = np.nonzero(frame.depth > 0)
            if len(rows) == 0:
                break
            k = rng.integers(len(rows))
            point = env.camera.pixel_to_world(frame, int(cols[k]), int(rows[k]))
            distance = float(np.linalg.norm(point - env.robot.arm_base_position()))
            result = env.control.mg.reach_and_push(point, np.zeros(3), env.np_random, lambda dt: None)
            out.append({"task": task, "distance": distance, "height": float(point[2]),
                        "plan_found": bool(result.success), "reason": result.reason})
        env.world.restore_state(state)
    env.close()
    return out


def by_band(rows: list[dict]) -> list[dict]:
    table = []
    for lo, hi in BANDS:
        band = [r for r in rows if lo <= r["distance"] < hi]
        table.append({"band_m": [lo, hi if math.isfinite(hi) else None], "samples": len(band),
                      "planned": sum(r["plan_found"] for r in band)})
    return table


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="results/movo")
    parser.add_argument("--robots", nargs="+", default=["fetch", "movo"])
    args = parser.parse_args()
    for robot in args.robots:
        rows = [row for task in TASKS for row in samples(robot, task)]
        planned = [r["distance"] for r in rows if r["plan_found"]]
        summary = {"robot": robot, "tasks": list(TASKS), "episodes_per_task": EPISODES, "pixels_per_state": PER_STATE,
                   "samples": len(rows), "planned": len(planned),
                   "farthest_planned_m": round(max(planned), 3) if planned else None,
                   "by_distance": by_band(rows), "rows": rows}
        Path(args.out, f"reach_{robot}.json").write_text(json.dumps(summary, indent=1))
        print(robot, f"{len(planned)}/{len(rows)} planned, farthest {summary['farthest_planned_m']} m")
        for band in summary["by_distance"]:
            print(f"  {band['band_m']}: {band['planned']}/{band['samples']}")


if __name__ == "__main__":
    main()
