"""Summarise results/oracles/*.json as a markdown table (issue 4 acceptance figures)."""

import json
import sys
from pathlib import Path

KEYS = ("success_rate", "spl", "closed_5", "closed_10", "closed_10_fraction", "subgoal_success_rate", "mean_steps")


def oracle_results(folder: str):
    """The ``relmogen oracle`` JSONs in ``folder``, by file name; others (``ik_tradeoff_runs.json``) are left out."""
    for path in sorted(Path(folder).glob("*.json")):
        result = json.loads(path.read_text())
        if "task" in result and "policy" in result:
            yield result


def main(folder: str = "results/oracles") -> None:
    print("| task | policy | planners | episodes | " + " | ".join(KEYS) + " |")
    print("|---|---|---|---|" + "---|" * len(KEYS))
    for d in oracle_results(folder):
        cells = [f"{d[k]:.3f}" if isinstance(d.get(k), float) else str(d.get(k, "-")) for k in KEYS]
        print(f"| {d['task']} | {d['policy']} | {d['base_planner']} | {d['episodes']} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(*sys.argv[1:])
