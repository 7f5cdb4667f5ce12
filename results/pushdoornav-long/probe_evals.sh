#!/usr/bin/env bash
# After the two learning-rate probes end: 100 deterministic episodes of their latest and best checkpoints
set -uo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
while pgrep -f "relmogen train --init-from runs/p1/" > /dev/null; do sleep 15; done
for r in runs/p2lr/PushDoorNav__relmogen-r__[0-9]__*[0-9]; do
  relmogen eval $r --seed 100000 --episodes 100 --json > /dev/null 2>> runs/p2lr/evals.log
  relmogen eval $r --checkpoint best --seed 100000 --episodes 100 --json > /dev/null 2>> runs/p2lr/evals.log
done
echo all-done >> runs/p2lr/evals.log
