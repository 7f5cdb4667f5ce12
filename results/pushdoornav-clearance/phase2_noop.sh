#!/usr/bin/env bash
# Phase 2 of twophase.sh (clearance CLEARANCE) from the same phase-1 run, with a larger cost per
# subgoal that executed nothing (env.noop_cost; the cpu preset's 0.1): SEED P2_CPU_HOURS CLEARANCE NOOP_COST
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1; P2=$2; C=$3; NOOP=$4
run=$(ls -d runs/clear-p1/PushDoorNav__relmogen-r__${SEED}__2* | tail -1)
relmogen train --init-from $run --init-replay --task PushDoorNav --algo relmogen-r --seed $SEED --preset cpu \
  --episodes 100000 --set max_cpu_hours=$P2 --set env.subgoal_feedback=true --set env.arm_collision_train=true \
  --set algo.learning_starts=0 --set 'env.arm_rrt=[100,4]' --set algo.ent_coef_min=0.02 \
  --set run.eval_episodes=20 --set env.base_goal_clearance=$C --set env.noop_cost=$NOOP --out runs/clear-noop --quiet
