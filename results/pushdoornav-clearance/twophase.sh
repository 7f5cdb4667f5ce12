#!/usr/bin/env bash
# The Table I recipe for PushDoorNav relmogen-r (../pushdoornav-table1-second/COMMANDS.md) with
# base goals kept CLEARANCE m from obstacles beyond the footprint in both phases
# (env.base_goal_clearance): phase 1, arm collision checking off, 1,000 episodes (runs/clear-p1);
# phase 2 from its weights and replay, checking on, P2_CPU_HOURS (runs/clear-p2).
# SEED P2_CPU_HOURS CLEARANCE
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1; P2=$2; C=$3
relmogen train --task PushDoorNav --algo relmogen-r --seed $SEED --preset cpu --episodes 1000 \
  --set env.subgoal_feedback=true --set env.base_goal_clearance=$C --out runs/clear-p1 --quiet
run=$(ls -d runs/clear-p1/PushDoorNav__relmogen-r__${SEED}__2* | tail -1)
relmogen train --init-from $run --init-replay --task PushDoorNav --algo relmogen-r --seed $SEED --preset cpu \
  --episodes 100000 --set max_cpu_hours=$P2 --set env.subgoal_feedback=true --set env.arm_collision_train=true \
  --set algo.learning_starts=0 --set 'env.arm_rrt=[100,4]' --set algo.ent_coef_min=0.02 \
  --set run.eval_episodes=20 --set env.base_goal_clearance=$C --out runs/clear-p2 --quiet
