#!/usr/bin/env bash
# phase 2 of PushDoorNav relmogen-r (the Table I recipe, base_goal=nearest_free) from phase 1's
# 1,000-episode weights and replay: SEED P2_CPU_HOURS [more train args, e.g. --set ... --out DIR]
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1; P2=$2; shift 2
run=$(ls -d runs/p1/PushDoorNav__relmogen-r__${SEED}__2* | tail -1)
relmogen train --init-from $run --init-replay --task PushDoorNav --algo relmogen-r --seed $SEED --preset cpu \
  --episodes 100000 --set max_cpu_hours=$P2 --set env.subgoal_feedback=true --set env.arm_collision_train=true \
  --set algo.learning_starts=0 --out runs/p2free --quiet "$@"
