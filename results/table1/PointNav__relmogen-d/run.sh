#!/usr/bin/env bash
# One seed of the PointNav relmogen-d row: train (cpu preset, 1,200 episodes, at most 0.6 CPU h;
# skipped if a finished run is in runs/sgpd-pointnav), then 100 greedy episodes, 100
# epsilon-greedy episodes (the run's final epsilon) and 50 greedy episodes with Lazy PRM for the
# base, seeds 100000+.  SEED
set -euo pipefail
cd "$(dirname "$0")/../../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1
run=$(ls -d runs/sgpd-pointnav/PointNav__relmogen-d__${SEED}__2*[0-9] 2>/dev/null | tail -1 || true)
if [ -z "$run" ] || [ ! -f "$run/done.json" ]; then
  relmogen train --task PointNav --algo relmogen-d --seed $SEED --preset cpu --episodes 1200 \
    --out runs/sgpd-pointnav --set run.eval_every_episodes=200 --set max_cpu_hours=0.6 --quiet
  run=$(ls -d runs/sgpd-pointnav/PointNav__relmogen-d__${SEED}__2*[0-9] | tail -1)
fi
relmogen eval $run --episodes 100 --seed 100000 --json > /dev/null 2>> $run.eval.log
relmogen eval $run --episodes 100 --seed 100000 --stochastic --json > /dev/null 2>> $run.eval.log
relmogen eval $run --episodes 50 --seed 100000 --base-planner lazy_prm --json > /dev/null 2>> $run.eval.log
