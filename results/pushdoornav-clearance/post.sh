#!/usr/bin/env bash
# evaluations of the phase-2 runs with base goal clearance (runs/clear-p2), two at a time: best and
# latest checkpoints on 100 episodes (seeds 100000+), then best with Lazy PRM for base and arm (50)
set -uo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
runs=$(ls -d runs/clear-p2/PushDoorNav__relmogen-r__[0-9]__*[0-9])
{
  for r in $runs; do echo "$r --checkpoint best --episodes 100"; done
  for r in $runs; do echo "$r --episodes 100"; done
  for r in $runs; do echo "$r --checkpoint best --episodes 50 --base-planner lazy_prm --arm-planner lazy_prm"; done
} | xargs -P 2 -L 1 bash -c 'relmogen eval $0 "$@" --seed 100000 --json > /dev/null 2>> runs/clear-p2/post.log || echo "failed: $0 $*" >> runs/clear-p2/post.log'
