#!/usr/bin/env bash
# Reward-only relmogen-d on TASK (cpu preset, 32 x 32 Q maps) with a longer exploration schedule,
# a larger replay and 3-step returns: TASK SEED CPU_HOURS [more train args]
# (why each: COMMANDS.md here)
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
TASK=$1; SEED=$2; HOURS=$3; shift 3
relmogen train --task $TASK --algo relmogen-d --seed $SEED --preset cpu --episodes 100000 \
  --set max_cpu_hours=$HOURS --set algo.exploration_initial_eps=1.0 --set algo.exploration_final_eps=0.05 \
  --set algo.exploration_steps=50000 --set algo.buffer_size=50000 --set algo.n_step_returns=3 \
  --out runs/sgpd-explore --quiet "$@"
