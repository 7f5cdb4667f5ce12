#!/usr/bin/env bash
# Fine-tune one PushDoorNav ReLMoGen-R policy of results/table1 (its best checkpoint, without
# its Fetch replay: those transitions are another body's) on Movo (relmogen/robots/assets/movo),
# under the settings of its own phase 2 (../pushdoornav-mg/phase2.sh), updates from 256
# transitions: SEED CPU_HOURS [more train args]
# The source runs are runs/p2mg/ on the machine that trained them.
set -euo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
SEED=$1; HOURS=$2; shift 2
source_run=$(ls -d runs/p2mg/PushDoorNav__relmogen-r__${SEED}__2* | tail -1)
relmogen train --init-from $source_run/checkpoints/$(cat $source_run/checkpoints/best) --task PushDoorNav --algo relmogen-r \
  --seed $SEED --preset cpu --episodes 100000 --set max_cpu_hours=$HOURS --set env.subgoal_feedback=true \
  --set env.arm_collision_train=true --set algo.learning_starts=256 --set 'env.arm_rrt=[100,4]' \
  --set algo.ent_coef_min=0.02 --set run.eval_every_episodes=100000 --robot movo \
  --out runs/finetune-robot --quiet "$@"
