#!/usr/bin/env bash
# One seed of this row from scratch: phase 1 (the clearance runs' phase 1, runs/clear-p1; skipped
# when a finished one is there, as the recipe is deterministic), phase 2
# (../../pushdoornav-noopcost/phase2.sh, P2_CPU_HOURS, periodic evaluations of EVAL_EPISODES on
# seeds 20000+; runs/noop-p2 for 20, runs/noop<EVAL_EPISODES>-p2 otherwise), then the 100-episode
# evaluation of `best` and the Lazy PRM planner swap (50 episodes), seeds 100000+.
# SEED P2_CPU_HOURS [EVAL_EPISODES (20)]
set -euo pipefail
cd "$(dirname "$0")/../../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1; P2=$2; EVAL=${3:-20}
OUT=runs/noop-p2; [ "$EVAL" = 20 ] || OUT=runs/noop$EVAL-p2
phase1=$(ls -d runs/clear-p1/PushDoorNav__relmogen-r__${SEED}__2* 2>/dev/null | tail -1 || true)
if [ -z "$phase1" ] || [ ! -f "$phase1/done.json" ]; then
  relmogen train --task PushDoorNav --algo relmogen-r --seed $SEED --preset cpu --episodes 1000 \
    --set env.subgoal_feedback=true --set env.base_goal_clearance=0.10 --out runs/clear-p1 --quiet
fi
bash results/pushdoornav-noopcost/phase2.sh $SEED $P2 0.10 1.0 $EVAL $OUT
run=$(ls -d $OUT/PushDoorNav__relmogen-r__${SEED}__2* | tail -1)
relmogen eval $run --checkpoint best --episodes 100 --seed 100000 --json > /dev/null 2>> $run.eval.log
relmogen eval $run --checkpoint best --episodes 50 --seed 100000 --base-planner lazy_prm \
  --arm-planner lazy_prm --json > /dev/null 2>> $run.eval.log
