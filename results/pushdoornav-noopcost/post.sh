#!/usr/bin/env bash
# evaluations of runs/noop-p2, two at a time, seeds 100000+, arm collision checking on: best and
# latest on 100 deterministic episodes, best sampled (100), best with Lazy PRM base + arm (50)
set -uo pipefail
cd /work/main && source .venv/bin/activate
runs=$(ls -d runs/noop-p2/PushDoorNav__relmogen-r__[0-9]__*[0-9])
{
  for r in $runs; do echo "$r --checkpoint best --episodes 100"; done
  for r in $runs; do echo "$r --episodes 100"; done
  for r in $runs; do echo "$r --checkpoint best --episodes 100 --stochastic"; done
  for r in $runs; do echo "$r --checkpoint best --episodes 50 --base-planner lazy_prm --arm-planner lazy_prm"; done
} | xargs -P 2 -L 1 bash -c 'relmogen eval $0 "$@" --seed 100000 --json > /dev/null 2>> runs/noop-p2/post.log || echo "failed: $0 $*" >> runs/noop-p2/post.log'
