#!/usr/bin/env bash
# Phase 3 of a Table I PushDoorNav relmogen-r run: copy the finished phase-2 run (runs/noop50-p2)
# to runs/noop50-p3 and continue it at a lower learning rate up to a total CPU budget, with the
# same periodic 50-episode validation. Then evaluate its last checkpoint (no choice) on 100
# episodes of seeds 100000+ and of fresh seeds 200000+.  SEED LR TOTAL_CPU_HOURS
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1; LR=$2; TOTAL=$3
src=$(ls -d runs/noop50-p2/PushDoorNav__relmogen-r__${SEED}__2*[0-9] | tail -1)
run=runs/noop50-p3/$(basename $src)
[ -d $run ] || cp -a $src $run
relmogen train --resume $run --quiet --set algo.learning_rate=$LR --set max_cpu_hours=$TOTAL
relmogen eval $run --episodes 100 --seed 100000 --json > /dev/null 2>> $run.eval.log
mkdir -p $run/eval_fresh_seeds
relmogen eval $run --episodes 100 --seed 200000 --json > $run/eval_fresh_seeds/latest_seed200000.json 2>> $run.eval.log
