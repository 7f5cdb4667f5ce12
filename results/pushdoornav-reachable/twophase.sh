#!/usr/bin/env bash
# two-phase PushDoorNav relmogen-r: SEED P2_CPU_HOURS
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1; P2=$2
relmogen train --task PushDoorNav --algo relmogen-r --seed $SEED --preset cpu --episodes 1000 \
  --set env.subgoal_feedback=true --out runs/p1 --quiet
run=$(ls -d runs/p1/PushDoorNav__relmogen-r__${SEED}__* | tail -1)
relmogen train --init-from $run --init-replay --task PushDoorNav --algo relmogen-r --seed $SEED --preset cpu \
  --episodes 100000 --set max_cpu_hours=$P2 --set env.subgoal_feedback=true --set env.arm_collision_train=true \
  --set algo.learning_starts=0 --out runs/p2 --quiet
