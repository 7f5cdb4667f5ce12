#!/usr/bin/env bash
# evaluations of runs/noop-p2, two at a time, seeds 100000+, arm collision checking on unless
# named: the Table II / A.2 settings of best (50), then latest and the sampled best (100).
# (best on 100 deterministic episodes ran first, when phase 2 had spent 0.55 CPU h:
#  relmogen eval RUN --checkpoint best --episodes 100 --seed 100000 --json)
set -uo pipefail
cd /work/main && source .venv/bin/activate
runs=$(ls -d runs/noop-p2/PushDoorNav__relmogen-r__[0-9]__*[0-9])
{
  for r in $runs; do echo "$r --checkpoint best --episodes 50 --base-planner lazy_prm --arm-planner lazy_prm"; done
  for r in $runs; do echo "$r --checkpoint best --episodes 50 --base-planner lazy_prm --arm-planner rrt_connect"; done
  for r in $runs; do echo "$r --checkpoint best --episodes 50 --arm-collision off"; done
  for r in $runs; do echo "$r --episodes 100"; done
  for r in $runs; do echo "$r --checkpoint best --episodes 100 --stochastic"; done
} | xargs -P 2 -L 1 bash -c 'relmogen eval $0 "$@" --seed 100000 --json > /dev/null 2>> runs/noop-p2/post.log || echo "failed: $0 $*" >> runs/noop-p2/post.log'
