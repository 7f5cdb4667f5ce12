"""Where the base stands when the arm pushes, from ``relmogen viz subgoals`` JSONs.

For every arm subgoal, the door distance (``door_distance``: metres from the doorway's line to
the base centre) of the base subgoal that ended last before it in the same episode; per figure
its mean and quartiles, and the median gap between the door and the base's edge (the median
minus the robot's ``base_radius``).

    relmogen analyse door-distance SUBGOALS.json... [--json]
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from relmogen.robots.spec import load_spec


def distances_at_arm_subgoals(figure: dict) -> list[float]:
    """Door distance of the base at each arm subgoal with a base subgoal before it."""
    base_by_episode: dict[int, list[dict]] = {}
    for record in figure["base"]:
        base_by_episode.setdefault(record["episode"], []).append(record)
    distances = []
    for arm in figure["arm"]:
        before = [b for b in base_by_episode.get(arm["episode"], []) if b["step"] < arm["step"]]
        if before and "door_distance" in before[-1]:
            distances.append(float(before[-1]["door_distance"]))
    return distances


def door_distance_row(path: Path) -> dict:
    """One figure's row: robot, checkpoint, episodes, SR, arm subgoals counted, arm plan rate,
    door distance mean and quartiles, and the median gap to the base's edge."""
    figure = json.loads(Path(path).read_text())
    d = np.array(distances_at_arm_subgoals(figure))
    quartiles = [round(float(q), 3) for q in np.percentile(d, [25, 50, 75])] if d.size else None
    radius = load_spec(figure.get("robot", "fetch")).base_radius
    return {"figure": Path(path).name, "robot": figure.get("robot"), "checkpoint": figure.get("checkpoint"),
            "episodes": figure.get("episodes"), "success_rate": figure.get("success_rate"),
            "arm_subgoals": int(d.size), "arm_plan_rate": figure.get("arm_plan_rate"),
            "mean_door_distance": round(float(d.mean()), 3) if d.size else None, "quartiles": quartiles,
            "median_gap_to_base_edge": round(quartiles[1] - radius, 3) if quartiles else None}
