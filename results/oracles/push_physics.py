"""Physics sub-steps during the arm's push: every oracle figure with 2 (the world's) and 1.

Run from the repository root: ``python results/oracles/push_physics.py SUB_STEPS OUT.json``
(SUB_STEPS: 2 or 1). Each task's oracle, 50 episodes (seeds 0-49), RRT-Connect for base and arm,
arm collision checking on, image size 128: the protocol of the other oracle JSONs here. Also
records the CPU seconds of each task's run.
"""

import json
import sys
import time
from dataclasses import replace

from relmogen.experiments.oracle import run_oracle
from relmogen.motion_generation.generator import MotionGenerator

TASKS = ("TabletopReachM", "PushDoorNav", "ButtonDoorNav", "InteractiveObstaclesNav", "ArrangeKitchenMM",
         "ArrangeChairMM")


def main(sub_steps: int, out: str) -> None:
    original = MotionGenerator._arm_config
    MotionGenerator._arm_config = lambda self: replace(original(self), push_sub_steps=sub_steps)
    results = {}
    for task in TASKS:
        start = time.process_time()
        result = run_oracle(task, episodes=50, quiet=True)
        results[task] = {key: result[key] for key in ("success_rate", "subgoal_success_rate", "closed_5", "closed_10")
                         if key in result} | {"cpu_s": round(time.process_time() - start, 1)}
        print(task, results[task], flush=True)
        with open(out, "w") as handle:
            json.dump({"push_sub_steps": sub_steps, "tasks": results}, handle, indent=1)


if __name__ == "__main__":
    main(int(sys.argv[1]), sys.argv[2])
