"""The shipped PushDoorNav policy under one base goal rule: one line per episode (success, door,
goal distance, and what each subgoal did), for results/oracles/base_goal.md.

    python results/oracles/base_goal_shipped.py BASE_GOAL EPISODES FIRST_SEED > out.log
"""

import collections
import shutil
import sys
import tempfile
from pathlib import Path

import yaml

from relmogen.experiments.shipped import open_shipped, shipped_policy_dir
from relmogen.experiments.rollout import run_episode

base_goal, episodes, first_seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
with tempfile.TemporaryDirectory() as folder:
    policy = Path(folder) / "policy"
    shutil.copytree(shipped_policy_dir("PushDoorNav-relmogen-r"), policy)
    config = yaml.safe_load((policy / "config.yaml").read_text())
    config["env"]["base_goal"] = base_goal
    (policy / "config.yaml").write_text(yaml.safe_dump(config))
    env, shipped = open_shipped(policy)
for seed in range(first_seed, first_seed + episodes):
    record = run_episode(env, shipped.act, seed)
    reasons = collections.Counter((s.get("subgoal_type"), s.get("reason") or "ok") for s in record.subgoals)
    m = record.metrics
    print(seed, "succ", m.get("success"), "door_open", m.get("door_opened"), "ang %.0f" % m.get("door_angle_deg", -1),
          "gd %.2f" % m.get("goal_distance", -1), "steps", record.steps, record.termination, dict(reasons), flush=True)
