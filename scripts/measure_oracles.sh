#!/usr/bin/env bash
# Issue 4 acceptance: every task's oracle with both planner families, and the random floor,
# 50 episodes each, subgoal-r, arm collision checking on. Writes results/oracles/*.json.
# Usage: bash scripts/measure_oracles.sh [EPISODES] [TASK...]
set -euo pipefail
cd "$(dirname "$0")/.."
episodes=${1:-50}; shift || true
tasks=${*:-PointNav TabletopReachM PushDoorNav ButtonDoorNav InteractiveObstaclesNav ArrangeKitchenMM ArrangeChairMM}
mkdir -p results/oracles
jobs=()
for task in $tasks; do
  jobs+=("$task oracle rrt_connect" "$task oracle lazy_prm" "$task random rrt_connect")
done
printf '%s\n' "${jobs[@]}" | xargs -P 2 -L 1 bash -c '
  out="results/oracles/${0}_${1}_${2}.json"
  .venv/bin/relmogen oracle --task "$0" --policy "$1" --base-planner "$2" --arm-planner "$2" \
      --episodes '"$episodes"' --json > "$out.tmp" 2>/dev/null && mv "$out.tmp" "$out" && echo "done $out"'
