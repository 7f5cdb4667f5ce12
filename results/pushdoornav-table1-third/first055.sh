#!/usr/bin/env bash
# The checkpoints that `best` named after the first 0.55 CPU h of phase 2 (the budget of the lost
# first runs of this recipe): seed 0 episode 400 (still `best`), seed 1 episode 500, seed 2
# episode 400 (the shipped demo policy); 100 deterministic episodes, seeds 100000+, checking on.
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
relmogen eval runs/noop-p2/PushDoorNav__relmogen-r__1__20261203-151405 --checkpoint evaluated_0000500 \
  --episodes 100 --seed 100000 --json > /dev/null
relmogen eval runs/noop-p2/PushDoorNav__relmogen-r__2__20261203-151456 --checkpoint evaluated_0000400 \
  --episodes 100 --seed 100000 --json > /dev/null
