"""Where the base stands when the arm pushes: for every arm subgoal in a ``relmogen viz subgoals``
JSON, the door distance (``door_distance``, m from the door) of the base subgoal that ended last
before it in the same episode; the mean and quartiles per figure.

    python door_distance.py subgoals_fetch.json subgoals_movo_zero_shot.json subgoals_movo_finetuned.json
"""

import json
import sys

import numpy as np


def distances_at_arm_subgoals(figure: dict) -> list[float]:
    base_by_episode: dict[int, list[dict]] = {}
    for record in figure["base"]:
        base_by_episode.setdefault(record["episode"], []).append(record)
    distances = []
    for arm in figure["arm"]:
        before = [b for b in base_by_episode.get(arm["episode"], []) if b["step"] < arm["step"]]
        if before and "door_distance" in before[-1]:
            distances.append(before[-1]["door_distance"])
    return distances


print("| figure | robot | checkpoint | episodes | SR | arm subgoals | arm plan rate | door distance at arm subgoals: mean (25%, 50%, 75%) |")
print("|---|---|---|---|---|---|---|---|")
for path in sys.argv[1:]:
    figure = json.loads(open(path).read())
    d = np.array(distances_at_arm_subgoals(figure))
    quartiles = ", ".join(f"{q:.2f}" for q in np.percentile(d, [25, 50, 75])) if len(d) else "-"
    print(f"| {path} | {figure['robot']} | {figure['checkpoint']} | {figure['episodes']} | {figure['success_rate']:.2f} | "
          f"{len(d)} | {figure['arm_plan_rate']:.2f} | {d.mean() if len(d) else float('nan'):.2f} m ({quartiles}) |")
