#!/usr/bin/env bash
# Phase 2 of a stable.sh run: a new run from SOURCE's latest weights, optimiser and replay
# (train --init-from --init-replay) with arm collision checking ON in training, epsilon going on
# from where SOURCE left it (EPS_NOW, linearly to 0.05 over STEPS_LEFT more steps) and the 6 CPU h
# budget minus what SOURCE spent (CPU_HOURS).   SOURCE TASK SEED EPS_NOW STEPS_LEFT CPU_HOURS [VARIANT]
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SOURCE=$1; TASK=$2; SEED=$3; EPS=$4; STEPS=$5; HOURS=$6; VARIANT=${7:-gamma}
case $VARIANT in
  gamma) extra=(--set algo.gamma=0.95) ;;
  slow) extra=(--set algo.learning_rate=0.0001 --set algo.target_update_interval=4096) ;;
  *) echo "unknown variant $VARIANT (gamma or slow)" >&2; exit 2 ;;
esac
relmogen train --task $TASK --algo relmogen-d --seed $SEED --preset cpu --episodes 100000 \
  --init-from $SOURCE --init-replay --set max_cpu_hours=$HOURS --set env.arm_collision_train=true \
  --set algo.exploration_initial_eps=$EPS --set algo.exploration_final_eps=0.05 --set algo.exploration_steps=$STEPS \
  --set algo.learning_starts=0 --set algo.buffer_size=50000 --set algo.n_step_returns=3 \
  --set env.push_frame=surface --set algo.qmap_skip=true --set run.eval_every_episodes=200 "${extra[@]}" \
  --out runs/sgpd-phase2 --quiet
