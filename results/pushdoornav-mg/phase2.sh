#!/usr/bin/env bash
# phase 2 of PushDoorNav relmogen-r (../table1/PushDoorNav__relmogen-r/COMMANDS.md: checking on,
# base_goal=nearest_free, from phase 1's weights and replay) with the arm's RRT-Connect at 100
# iterations x 4 restarts, a temperature floor of 0.02 and 20-episode periodic evaluations that
# choose checkpoints/best: SEED P2_CPU_HOURS
set -euo pipefail
cd /work/main && source .venv/bin/activate
SEED=$1; P2=$2
run=$(ls -d runs/p1/PushDoorNav__relmogen-r__${SEED}__2* | tail -1)
relmogen train --init-from $run --init-replay --task PushDoorNav --algo relmogen-r --seed $SEED --preset cpu \
  --episodes 100000 --set max_cpu_hours=$P2 --set env.subgoal_feedback=true --set env.arm_collision_train=true \
  --set algo.learning_starts=0 --set 'env.arm_rrt=[100,4]' --set algo.ent_coef_min=0.02 \
  --set run.eval_episodes=20 --out runs/p2mg --quiet
