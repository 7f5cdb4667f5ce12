#!/usr/bin/env bash
# After the three phase-2 runs were stopped: evaluations of their best checkpoints (Table II,
# transfer) and latest ones, and the fine-tuning of the best one to office_B and to Movo, two jobs
# at a time on the 2 cores.
set -uo pipefail
cd "$(dirname "$0")/../.." && { [ ! -f .venv/bin/activate ] || source .venv/bin/activate; }
runs=$(ls -d runs/p2free/PushDoorNav__relmogen-r__[0-9]__*[0-9])
jobs=runs/p2free/jobs.txt; : > $jobs
add() { echo "$*" >> $jobs; }
for r in $runs; do add eval $r --checkpoint best --episodes 100; done
add finetune scene
add finetune robot
for r in $runs; do add eval $r --episodes 100; done
for r in $runs; do add eval $r --checkpoint best --episodes 50 --base-planner lazy_prm --arm-planner lazy_prm; done
for r in $runs; do add eval $r --checkpoint best --episodes 50 --base-planner rrt_connect --arm-planner lazy_prm; done
for r in $runs; do add eval $r --checkpoint best --episodes 50 --base-planner lazy_prm --arm-planner rrt_connect; done
for r in $runs; do add eval $r --checkpoint best --episodes 50 --arm-collision off; done
for r in $runs; do add eval $r --checkpoint best --episodes 50 --scene B; done
for r in $runs; do add eval $r --checkpoint best --episodes 50 --robot movo; done
xargs -P 2 -L 1 bash results/pushdoornav-long/job.sh < $jobs
echo all-done >> runs/p2free/jobs.log
