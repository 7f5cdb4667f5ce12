#!/usr/bin/env bash
# Final evaluations of training runs, two at a time (one per core). Each `relmogen eval` writes
# its JSON into RUN_DIR/eval/ (named after scene, planners, collision setting and episodes),
# where `relmogen report` finds it. Evaluation episodes use seeds 100000, 100001, ... (never
# the training seeds).
# Usage: bash results/sgpd-first/evaluate_runs.sh EPISODES "EXTRA EVAL ARGS" RUN_DIR...
#   e.g. bash results/sgpd-first/evaluate_runs.sh 100 "--base-planner lazy_prm --arm-planner lazy_prm" runs/x/*relmogen-r*
set -euo pipefail
cd "$(dirname "$0")/../.."  # the repository root
if [ $# -lt 3 ]; then
  echo "usage: bash results/sgpd-first/evaluate_runs.sh EPISODES \"EXTRA EVAL ARGS\" RUN_DIR..." >&2
  exit 2
fi
episodes=$1; extra=$2; shift 2
printf '%s\n' "$@" | xargs -P 2 -I{} bash -c '
  run="{}"
  .venv/bin/relmogen eval "$run" --episodes '"$episodes"' --seed 100000 '"$extra"' --json 2>/dev/null | tail -n 1
' 
