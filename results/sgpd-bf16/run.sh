#!/usr/bin/env bash
# The PointNav relmogen-d Table I recipe (../table1/PointNav__relmogen-d/run.sh: cpu preset,
# 1,200 episodes, at most 0.6 CPU h) with the Q-map network under bfloat16 autocast
# (algo.qmap_bf16=true), then 100 greedy episodes on seeds 100000+: does bf16 learn as float32 did?  SEED
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1
relmogen train --task PointNav --algo relmogen-d --seed $SEED --preset cpu --episodes 1200 \
  --out runs/sgpd-bf16 --set run.eval_every_episodes=200 --set max_cpu_hours=0.6 --set algo.qmap_bf16=true --quiet
run=$(ls -d runs/sgpd-bf16/PointNav__relmogen-d__${SEED}__2*[0-9] | tail -1)
relmogen eval $run --episodes 100 --seed 100000 --json > /dev/null 2>> $run.eval.log
