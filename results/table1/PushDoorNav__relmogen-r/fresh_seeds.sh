#!/usr/bin/env bash
# `best` of each run on 100 more deterministic episodes, seeds 200000-200099, checking on: test
# episodes that no choice of this recipe ever looked at (the switch to a 50-episode validation
# block was made after the 20-episode block's choices were tested on seeds 100000+). The results go
# to RUN/eval_fresh_seeds/ so that the report does not pool them with the seeds-100000 evaluation.
# RUN_DIR...
set -uo pipefail
cd "$(dirname "$0")/../../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
printf '%s\n' "$@" | xargs -P 2 -I{} bash -c 'relmogen eval {} --checkpoint best --episodes 100 --seed 200000 --json \
  > /dev/null 2>> {}.fresh.log && mkdir -p {}/eval_fresh_seeds && mv {}/eval/*_seed200000.json {}/eval_fresh_seeds/'
