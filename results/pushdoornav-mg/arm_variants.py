"""The shipped PushDoorNav policy under arm motion-generator variants (checking on): SR, the
subgoal outcomes per episode and the CPU seconds per episode, on the same evaluation seeds.

    python results/pushdoornav-mg/arm_variants.py NAME EPISODES FIRST_SEED [key=value ...]

keys: ArmConfig fields (plan_attempts=6, ik_restarts=...) and rrt.<RRTConnectParams field>
(rrt.iterations=100) for the arm's RRT-Connect. One JSON line per variant on stdout.
"""

import collections
import json
import re
import sys
import time
from dataclasses import replace

from relmogen.experiments.shipped import open_shipped, shipped_policy_dir
from relmogen.experiments.rollout import run_episode
from relmogen.motion_generation import arm as arm_module
from relmogen.motion_generation import generator as generator_module

name, episodes, first_seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
overrides = dict(arg.split("=", 1) for arg in sys.argv[4:])
arm_overrides = {k: type(getattr(arm_module.ArmConfig(), k))(v) for k, v in overrides.items() if not k.startswith("rrt.")}
rrt_overrides = {k[4:]: int(v) for k, v in overrides.items() if k.startswith("rrt.")}

original_arm_config = generator_module.MotionGenerator._arm_config
generator_module.MotionGenerator._arm_config = lambda self: replace(original_arm_config(self), **arm_overrides)
original_set_planner = arm_module.ArmMotion.set_planner


def set_planner(self, planner, params=None, **kwargs):
    extra = rrt_overrides if planner == "rrt_connect" else {}
    original_set_planner(self, planner, params, **{**extra, **kwargs})


arm_module.ArmMotion.set_planner = set_planner
env, shipped = open_shipped(shipped_policy_dir("PushDoorNav-relmogen-r"))
outcomes, successes = collections.Counter(), []
cpu_start = time.process_time()
for seed in range(first_seed, first_seed + episodes):
    record = run_episode(env, shipped.act, seed)
    successes.append(bool(record.metrics.get("success")))
    for s in record.subgoals:
        reason = re.sub(r"\d[\d.]*", "#", (s.get("reason") or "ok").split(";")[-1].strip())
        outcomes[f"{s.get('subgoal_type')}: {reason}"] += 1
print(json.dumps({"variant": name, "overrides": overrides, "episodes": episodes,
                  "success_rate": sum(successes) / episodes,
                  "cpu_s_per_episode": (time.process_time() - cpu_start) / episodes,
                  "per_episode": {k: round(v / episodes, 2) for k, v in sorted(outcomes.items())}}), flush=True)
