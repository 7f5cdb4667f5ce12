#!/usr/bin/env bash
# Continue a phase-2 run of phase2.sh to a total of CPU_HOURS (its periodic evaluations on the
# same fixed block keep choosing checkpoints/best): RUN_DIR CPU_HOURS
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
relmogen train --resume $1 --set max_cpu_hours=$2 --quiet
