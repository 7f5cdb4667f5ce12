"""One ``bench_training_run`` (relmogen-r, cpu preset, PushDoorNav, 1000 subgoals) of whichever
relmogen is first on PYTHONPATH: an A/B of two checkouts alternated on one machine, e.g.

    git worktree add /tmp/base 466a09c
    for i in 1 2; do
      PYTHONPATH=/tmp/base python results/bench_training_run_ab.py
      PYTHONPATH=$PWD python results/bench_training_run_ab.py
    done
"""

import json

import relmogen
from relmogen.bench.train_bench import bench_training_run

if __name__ == "__main__":  # the environment workers import this module
    run = bench_training_run("PushDoorNav", "cpu", 1000)
    print(relmogen.__file__, json.dumps({key: run[key] for key in
                                         ("episodes_per_cpu_hour", "subgoals_per_cpu_s", "cpu_s", "time_shares")}))
