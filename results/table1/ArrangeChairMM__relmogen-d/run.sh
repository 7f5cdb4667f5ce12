#!/usr/bin/env bash
# One seed of the ArrangeChairMM relmogen-d row, reward only: the sgpd-explore gamma recipe
# (results/sgpd-explore/stable.sh gamma: cpu preset, 32 x 32 Q maps, pushes into the seen surface,
# skip head, gamma 0.95, 3-step returns, replay 5e4, epsilon 1.0 -> 0.05 over 5e4 steps, uniform
# exploratory actions) for the full budget of 6 CPU h; a run stopped early (SIGTERM) is
# resumed, and its CPU time adds up across resumes. Then 50 greedy and 50 epsilon-greedy episodes
# (the run's final epsilon), arm collision checking on, seeds 100000+.  SEED
set -euo pipefail
cd /work/main && source .venv/bin/activate
SEED=$1; OUT=runs/sgpd-stable-gamma
run=$(ls -d $OUT/ArrangeChairMM__relmogen-d__${SEED}__2*[0-9] 2>/dev/null | tail -1 || true)
if [ -z "$run" ]; then
  bash results/sgpd-explore/stable.sh gamma ArrangeChairMM $SEED 6
  run=$(ls -d $OUT/ArrangeChairMM__relmogen-d__${SEED}__2*[0-9] | tail -1)
elif [ ! -f "$run/done.json" ]; then
  relmogen train --resume $run --quiet
fi
[ -f "$run/done.json" ] || { echo "$run stopped before its budget; run this again to resume" >&2; exit 1; }
relmogen eval $run --episodes 50 --seed 100000 --json > /dev/null 2>> $run.eval.log
relmogen eval $run --episodes 50 --seed 100000 --stochastic --json > /dev/null 2>> $run.eval.log
