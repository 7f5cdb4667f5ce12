#!/usr/bin/env bash
# phase 2 of PushDoorNav relmogen-r (../pushdoornav-long/phase2.sh: checking on,
# base_goal=nearest_free, from phase 1's weights and replay) with the arm's RRT-Connect at 100
# iterations x 4 restarts, a temperature floor of 0.02 and 20-episode periodic evaluations that
# choose checkpoints/best: SEED P2_CPU_HOURS
set -euo pipefail
bash "$(dirname "$0")/../pushdoornav-long/phase2.sh" "$1" "$2" --set 'env.arm_rrt=[100,4]' \
  --set algo.ent_coef_min=0.02 --set run.eval_episodes=20 --out runs/p2mg
