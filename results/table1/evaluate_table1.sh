#!/usr/bin/env bash
# Table I evaluations of finished runs (issue 21 protocol): 100 deterministic episodes, seeds
# 100000 and up, arm collision checking on; the same with Lazy PRM for base and arm (planner
# swap); and 100 stochastic episodes (sampled subgoals) beside them.
# Usage: bash results/table1/evaluate_table1.sh RUN_DIR...
set -euo pipefail
for run in "$@"; do
  .venv/bin/relmogen eval "$run" --episodes 100 --seed 100000 --json
  .venv/bin/relmogen eval "$run" --episodes 100 --seed 100000 --base-planner lazy_prm --arm-planner lazy_prm --json
  .venv/bin/relmogen eval "$run" --episodes 100 --seed 100000 --stochastic --json
done
