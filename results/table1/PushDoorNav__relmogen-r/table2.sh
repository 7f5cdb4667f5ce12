#!/usr/bin/env bash
# The rest of Tables II / A.2 for the `best` models, 50 episodes each, seeds 100000+, two at a time:
# Lazy PRM base with RRT-Connect arm, RRT-Connect base with Lazy PRM arm, arm collision checking off.
# [OUT (runs/noop-p2): the phase-2 folder of rerun.sh]
set -uo pipefail
cd "$(dirname "$0")/../../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
OUT=${1:-runs/noop-p2}
runs=$(ls -d $OUT/PushDoorNav__relmogen-r__[0-2]__*[0-9])
{
  for r in $runs; do echo "$r --base-planner lazy_prm --arm-planner rrt_connect"; done
  for r in $runs; do echo "$r --base-planner rrt_connect --arm-planner lazy_prm"; done
  for r in $runs; do echo "$r --arm-collision off"; done
} | xargs -P 2 -L 1 bash -c 'relmogen eval $0 "$@" --checkpoint best --episodes 50 --seed 100000 --json > /dev/null 2>> $(dirname $0)/table2.log || echo "failed: $0 $*" >> $(dirname $0)/table2.log'
