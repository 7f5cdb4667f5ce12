#!/usr/bin/env bash
# Phase 2 of ../pushdoornav-clearance/twophase.sh (checking on, base-goal clearance CLEARANCE) from
# the same phase-1 run, with cost NOOP_COST per subgoal that executed nothing (env.noop_cost; the
# cpu preset's 0.1) and periodic evaluations on one fixed block of 20 episodes (run.eval_seed=20000).
# run.keep_evaluated (added for the Table I rerun; it changes no training) keeps each evaluated model.
# The Table I rerun with 50-episode evaluations passes EVAL_EPISODES=50 and its own OUT.
# SEED P2_CPU_HOURS CLEARANCE NOOP_COST [EVAL_EPISODES (20)] [OUT (runs/noop-p2)]
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1; P2=$2; C=$3; NOOP=$4; EVAL=${5:-20}; OUT=${6:-runs/noop-p2}
run=$(ls -d runs/clear-p1/PushDoorNav__relmogen-r__${SEED}__2* | tail -1)
relmogen train --init-from $run --init-replay --task PushDoorNav --algo relmogen-r --seed $SEED --preset cpu \
  --episodes 100000 --set max_cpu_hours=$P2 --set env.subgoal_feedback=true --set env.arm_collision_train=true \
  --set algo.learning_starts=0 --set 'env.arm_rrt=[100,4]' --set algo.ent_coef_min=0.02 \
  --set run.eval_episodes=$EVAL --set run.eval_seed=20000 --set env.base_goal_clearance=$C \
  --set env.noop_cost=$NOOP --set run.keep_evaluated=true --out $OUT --quiet
