#!/usr/bin/env bash
# one job of post.sh: "eval RUN ARGS..." or "finetune scene|robot"
set -uo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
log=runs/p2free/jobs.log
echo "$(date +%T) start $*" >> $log
best_run() {  # the best checkpoint of the phase-2 run whose best checkpoint scored highest over 100 episodes (waits for the three evaluations)
  until [ $(ls runs/p2free/*/eval/eval_office_A_rrt_connect_rrt_connect_collision-on_100ep_best_*.json 2>/dev/null | wc -l) -ge 3 ]; do sleep 10; done
  python - <<'PY'
import glob, json, pathlib
files = glob.glob("runs/p2free/*/eval/eval_office_A_rrt_connect_rrt_connect_collision-on_100ep_best_*.json")
best = max(files, key=lambda f: json.load(open(f))["success_rate"])
checkpoints = pathlib.Path(best).parent.parent / "checkpoints"
print(checkpoints / (checkpoints / "best").read_text().strip())
PY
}
[ $1 = finetune ] && [ -e runs/p2free/skip_finetune ] && { echo "skipped $*" >> $log; exit 0; }
[ -e runs/p2free/skip_transfer ] && [[ "$*" == *"--scene B"* || "$*" == *"--robot movo"* ]] && { echo "skipped $*" >> $log; exit 0; }
case $1 in
  eval) shift; run=$1; shift
        relmogen eval $run --seed 100000 --json "$@" > /dev/null 2>> $log || echo "failed: eval $run $*" >> $log ;;
  finetune)
    src=$(best_run); seed=$(basename $(dirname $(dirname $src)) | cut -d_ -f5)
    if [ $2 = scene ]; then
      relmogen train --init-from $src --init-replay --task PushDoorNav --algo relmogen-r --seed $seed --preset cpu \
        --episodes 100000 --set max_cpu_hours=0.35 --set env.subgoal_feedback=true --set env.arm_collision_train=true \
        --set algo.learning_starts=0 --set env.second_scene=office_B --out runs/ft-scene --quiet 2>> $log
      ft=$(ls -d runs/ft-scene/PushDoorNav__*[0-9] | tail -1)
      relmogen eval $ft --seed 100000 --episodes 50 --scene B --json > /dev/null 2>> $log
      relmogen eval $ft --seed 100000 --episodes 50 --scene A --json > /dev/null 2>> $log
    else
      relmogen train --init-from $src --init-replay --robot movo --task PushDoorNav --algo relmogen-r --seed $seed --preset cpu \
        --episodes 100000 --set max_cpu_hours=0.35 --set env.subgoal_feedback=true --set env.arm_collision_train=true \
        --set algo.learning_starts=0 --out runs/ft-robot --quiet 2>> $log
      ft=$(ls -d runs/ft-robot/PushDoorNav__*[0-9] | tail -1)
      relmogen eval $ft --seed 100000 --episodes 50 --json > /dev/null 2>> $log
      relmogen viz subgoals $ft --episodes 20 --out results/finetune-robot/subgoals_movo_finetuned.png 2>> $log
      relmogen viz subgoals $src --episodes 20 --robot movo --out results/finetune-robot/subgoals_movo_zeroshot.png 2>> $log
      relmogen viz subgoals $src --episodes 20 --out results/finetune-robot/subgoals_fetch.png 2>> $log
    fi ;;
esac
echo "$(date +%T) end $*" >> $log
