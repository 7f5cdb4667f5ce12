"""Choose a run's model on a longer validation block than its trainer used.

Each model a run's periodic evaluations scored (``eval_during_training.jsonl``; kept as
``checkpoints/evaluated_<episode>`` with ``run.keep_evaluated``) can play more validation
episodes, ``relmogen eval RUN --checkpoint evaluated_<episode> --seed S`` with the result moved
to ``RUN/validation/``. Pooled with the periodic evaluation, each model's success rate and mean
return over all its episodes rank the models: success rate, then mean return (the trainer's rule).

    relmogen analyse choose RUN... [--json OUT.json]
"""

from __future__ import annotations

import json
from pathlib import Path


def validation_rows(run: Path) -> list[dict]:
    """Per model with extra validation (``RUN/validation/*.json``): its periodic and extra success
    rates and episodes, and success rate and mean return pooled over both."""
    run = Path(run)
    periodic = {entry["episode"]: entry
                for entry in map(json.loads, (run / "eval_during_training.jsonl").read_text().splitlines())}
    rows = []
    for path in sorted((run / "validation").glob("*.json")):
        extra = json.loads(path.read_text())
        episode = int(extra.get("checkpoint_episode") or extra["checkpoint"].rsplit("_", 1)[1])
        first = periodic[episode]
        n1, n2 = first["episodes"], extra["episodes"]
        rows.append({"episode": episode, "periodic_episodes": n1, "periodic_success_rate": first["success_rate"],
                     "extra_episodes": n2, "extra_success_rate": extra["success_rate"],
                     "success_rate": (n1 * first["success_rate"] + n2 * extra["success_rate"]) / (n1 + n2),
                     "mean_return": (n1 * first["mean_return"] + n2 * extra["mean_return"]) / (n1 + n2)})
    return sorted(rows, key=lambda row: row["episode"])


def choose(run: Path) -> dict:
    """``{"run", "chosen_episode", "checkpoint", "models"}``: the best model by pooled success
    rate, then pooled mean return; the earliest of equals."""
    rows = validation_rows(run)
    if not rows:
        raise ValueError(f"{run} has no validation/*.json: evaluate its kept models there first")
    best = max(rows, key=lambda row: (row["success_rate"], row["mean_return"], -row["episode"]))
    return {"run": Path(run).name, "chosen_episode": best["episode"],
            "checkpoint": f"evaluated_{best['episode']:07d}", "models": rows}
