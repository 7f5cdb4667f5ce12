#!/usr/bin/env bash
# Continue a finished 2,600-episode seed of the ArrangeChairMM relmogen-d row to 4,600 episodes, the
# most the issue's 6 CPU h per seed buys seeds 0 and 1 (their first 2,600 episodes ran on the slow
# AMD host), then evaluate it as run.sh does. The continuation is a copy in runs/sgpd-stable-gamma-6h/,
# so the 2,600-episode run and its evaluations stay as they were; ../relmogen-d-seed.sh resumes it
# (there, or restored from a carried model) and evaluates it.  SEED
set -euo pipefail
cd "$(dirname "$0")/../../.."
[[ $# -eq 1 && $1 =~ ^[0-9]+$ ]] || { echo "usage: $0 SEED" >&2; exit 2; }
OUT=runs/sgpd-stable-gamma-6h
if ! ls -d $OUT/ArrangeChairMM__relmogen-d__$1__2*[0-9] > /dev/null 2>&1; then  # not yet continued: copy the finished run
  SRC=$(ls -d runs/sgpd-stable-gamma/ArrangeChairMM__relmogen-d__$1__2*[0-9] 2>/dev/null | tail -1 || true)
  [ -n "$SRC" ] && [ -f "$SRC/done.json" ] || { echo "seed $1 has no finished run: bash $(dirname "$0")/run.sh $1 first" >&2; exit 1; }
  mkdir -p $OUT && cp -r "$SRC" $OUT/
fi
exec bash results/table1/relmogen-d-seed.sh gamma-6h ArrangeChairMM "$1" 4600
