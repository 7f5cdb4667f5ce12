#!/usr/bin/env bash
# phase 2 as phase2.sh, with the SAC step size lowered for the fine-tuning: SEED P2_CPU_HOURS LR
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1; P2=$2; LR=$3
run=$(ls -d runs/p1/PushDoorNav__relmogen-r__${SEED}__2* | tail -1)
relmogen train --init-from $run --init-replay --task PushDoorNav --algo relmogen-r --seed $SEED --preset cpu \
  --episodes 100000 --set max_cpu_hours=$P2 --set env.subgoal_feedback=true --set env.arm_collision_train=true \
  --set algo.learning_starts=0 --set algo.learning_rate=$LR --out runs/p2lr --quiet
