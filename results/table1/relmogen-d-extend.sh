#!/usr/bin/env bash
# Continue a finished seed of a relmogen-d Table I row to EPISODES episodes (within the issue's
# 6 CPU h per seed; max_cpu_hours in the run's config stops it earlier), then evaluate it as
# relmogen-d-seed.sh does. The continuation is a copy in runs/sgpd-stable-VARIANT-6h/, so the
# finished run and its evaluations stay as they were; relmogen-d-seed.sh resumes the copy (there,
# or restored from a carried model) and evaluates it.
#   relmogen-d-extend.sh VARIANT TASK SEED EPISODES
set -euo pipefail
cd "$(dirname "$0")/../.."
[[ $# -eq 4 && $3 =~ ^[0-9]+$ && $4 =~ ^[0-9]+$ ]] || { echo "usage: $0 VARIANT TASK SEED EPISODES (SEED and EPISODES integers)" >&2; exit 2; }
VARIANT=$1; TASK=$2; SEED=$3; OUT=runs/sgpd-stable-$VARIANT-6h
if ! ls -d $OUT/${TASK}__relmogen-d__${SEED}__2*[0-9] > /dev/null 2>&1; then  # not yet continued: copy the finished run
  SRC=$(ls -d runs/sgpd-stable-$VARIANT/${TASK}__relmogen-d__${SEED}__2*[0-9] 2>/dev/null | tail -1 || true)
  [ -n "$SRC" ] && [ -f "$SRC/done.json" ] || { echo "$TASK seed $SEED has no finished run in runs/sgpd-stable-$VARIANT: run its row's run.sh $SEED first" >&2; exit 1; }
  mkdir -p $OUT && cp -r "$SRC" $OUT/
fi
exec bash results/table1/relmogen-d-seed.sh $VARIANT-6h $TASK $SEED $4
