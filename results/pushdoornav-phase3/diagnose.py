"""Where does a PushDoorNav relmogen-r policy fail? Runs a checkpoint's deterministic policy (arm
collision checking on) and writes one JSON line per episode: its metrics and each subgoal's type,
plan outcome and reason, so failed episodes can be read and counted.

    python results/pushdoornav-phase3/diagnose.py RUN --checkpoint best --episodes 50 --seed 20000 --out F.jsonl
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path

from relmogen.experiments.train import env_kwargs
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.evaluate import load_policy, policy_act, seeded_action_sampling
from relmogen.experiments.rollout import run_episode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--checkpoint", default="best")
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--seed", type=int, default=20000)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    model, config, _ = load_policy(args.run, checkpoint=args.checkpoint)
    env = RelmogenEnv(**env_kwargs(config, arm_collision=True))
    act = policy_act(model, config, env)
    failures = Counter()
    with seeded_action_sampling(args.seed), open(args.out, "w") as out:
        for episode in range(args.episodes):
            record = run_episode(env, act, args.seed + episode)
            row = {"seed": args.seed + episode, "steps": record.steps, "termination": record.termination,
                   "metrics": record.metrics, "subgoals": [
                       {k: s[k] for k in ("subgoal_type", "plan_found", "reason", "repeat")} for s in record.subgoals]}
            out.write(json.dumps(row, default=float) + "\n")
            if not record.metrics.get("success"):
                failures["door never opened" if not record.metrics.get("door_opened") else "opened, goal not reached"] += 1
    env.close()
    print(json.dumps({"episodes": args.episodes, "failures": dict(failures)}))


if __name__ == "__main__":
    main()
