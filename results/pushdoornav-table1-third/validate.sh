#!/usr/bin/env bash
# A larger validation block for choosing the checkpoint: every model that phase 2 evaluated
# (checkpoints/evaluated_*, run.keep_evaluated) plays 30 more deterministic episodes, seeds
# 20020-20049, checking on; with the 20 of training (seeds 20000-20019) that is 50 per model.
# The results go to RUN/validation/ (not RUN/eval/, the test evaluations); choose.py ranks them.
# RUN_DIR...
set -uo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
for r in "$@"; do for c in $r/checkpoints/evaluated_*; do echo "$r $(basename $c)"; done; done |
  xargs -P 2 -L 1 bash -c 'relmogen eval $0 --checkpoint $1 --episodes 30 --seed 20020 --json > /dev/null 2>> $0.validate.log &&
    mkdir -p $0/validation && mv $0/eval/*_$1_seed20020.json $0/validation/'
