#!/usr/bin/env bash
# Continue a Table I PushDoorNav ReLMoGen-R run from its best checkpoint (with its replay) in
# office_A under its phase-2 settings, but with a narrower actor: target entropy -8 (SB3's
# -dim(A)) and a temperature floor of 0.005 instead of -4 and 0.02: SEED CPU_HOURS [more train args]
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1; HOURS=$2; shift 2
source_run=$(ls -d runs/p2mg/PushDoorNav__relmogen-r__${SEED}__2* | tail -1)
relmogen train --init-from $source_run/checkpoints/best --init-replay --task PushDoorNav --algo relmogen-r \
  --seed $SEED --preset cpu --episodes 100000 --set max_cpu_hours=$HOURS --set env.subgoal_feedback=true \
  --set env.arm_collision_train=true --set algo.learning_starts=0 --set 'env.arm_rrt=[100,4]' \
  --set algo.ent_coef_min=0.005 --set algo.target_entropy=-8 --set run.eval_episodes=20 \
  --out runs/narrow --quiet "$@"
