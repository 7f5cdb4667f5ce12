#!/usr/bin/env bash
# The ButtonDoorNav relmogen-d Table I recipe (results/sgpd-explore/stable.sh gamma) with half the
# gradient updates: one batch of 32 per 8 transitions (algo.train_freq=4, replay ratio 4) instead of
# per 4 (the paper's ratio 8). The trainer's updates take about 93% of its CPU samples, so each CPU
# hour holds more episodes (measured: 1.2x; COMMANDS.md).  SEED [CPU_HOURS, default 6]
set -euo pipefail
[[ $# -ge 1 && $1 =~ ^[0-9]+$ ]] || { echo "usage: $0 SEED [CPU_HOURS]" >&2; exit 2; }
exec bash "$(dirname "$0")/../sgpd-explore/stable.sh" gamma ButtonDoorNav "$1" "${2:-6}" \
  --set algo.train_freq=4 --out runs/sgpd-ratio
