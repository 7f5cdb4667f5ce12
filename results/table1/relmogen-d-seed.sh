#!/usr/bin/env bash
# One reward-only seed of a relmogen-d Table I row (issue 22): trains TASK on the sgpd-explore
# recipe VARIANT (results/sgpd-explore/stable.sh: cpu preset, 32 x 32 Q maps, pushes into the
# seen surface, skip head, 3-step returns, replay 5e4, epsilon 1.0 -> 0.05 over 5e4 steps) until
# the issue's budget of 6 CPU h is spent or EPISODES episodes are done. A run stopped early
# (SIGTERM), or finished at fewer than EPISODES episodes, is resumed from runs/, its CPU time
# adding up across resumes. A finished run is then evaluated on 50 greedy and 50 epsilon-greedy
# episodes (the run's final epsilon), arm collision checking on, seeds 100000+.
#   relmogen-d-seed.sh VARIANT TASK SEED [EPISODES]   (runs live in runs/sgpd-stable-VARIANT/)
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
[[ $# -ge 3 && $3 =~ ^[0-9]+$ && ${4:-1} =~ ^[0-9]+$ ]] || { echo "usage: $0 VARIANT TASK SEED [EPISODES] (SEED and EPISODES integers)" >&2; exit 2; }
VARIANT=$1; TASK=$2; SEED=$3; EPISODES=${4:-100000}; OUT=runs/sgpd-stable-$VARIANT
latest_run() { ls -d $OUT/${TASK}__relmogen-d__${SEED}__2*[0-9] 2>/dev/null | tail -1 || true; }
run=$(latest_run)
if [ -z "$run" ]; then
  bash results/sgpd-explore/stable.sh $VARIANT $TASK $SEED 6 --episodes $EPISODES
  run=$(latest_run)
elif [ ! -f "$run/done.json" ] || [ "$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["episodes"])' "$run/done.json")" -lt "$EPISODES" ]; then
  relmogen train --resume $run --episodes $EPISODES --quiet  # unfinished, or finished at fewer episodes
fi
[ -f "$run/done.json" ] || { echo "$run stopped before its budget; run this again to resume" >&2; exit 1; }
relmogen eval $run --episodes 50 --seed 100000 --json > /dev/null 2>> $run.eval.log
relmogen eval $run --episodes 50 --seed 100000 --stochastic --json > /dev/null 2>> $run.eval.log
