"""Ranks each phase-2 model of the runs given on 50 validation episodes: the 20 of its periodic
evaluation (eval_during_training.jsonl, seeds 20000-20019) and the 30 of validate.sh (RUN/validation/,
seeds 20020-20049), by success rate, then mean return (the trainer's rule). Prints a table and
writes validation.json beside this script.

    python results/pushdoornav-table1-third/choose.py RUN_DIR...
"""
import json
import sys
from pathlib import Path


def validation_of(run: Path) -> list[dict]:
    periodic = {e["episode"]: e for e in map(json.loads, (run / "eval_during_training.jsonl").read_text().splitlines())}
    rows = []
    for path in sorted((run / "validation").glob("*.json")):
        extra = json.loads(path.read_text())
        episode = int(extra["checkpoint"].split("_")[1])
        first = periodic[episode]
        n1, n2 = first["episodes"], extra["episodes"]
        rows.append({"episode": episode, "validation_20": first["success_rate"], "validation_30": extra["success_rate"],
                     "success_rate": (n1 * first["success_rate"] + n2 * extra["success_rate"]) / (n1 + n2),
                     "mean_return": (n1 * first["mean_return"] + n2 * extra["mean_return"]) / (n1 + n2)})
    return rows


def main(runs: list[Path]) -> None:
    chosen = {}
    for run in runs:
        rows = validation_of(run)
        best = max(rows, key=lambda row: (row["success_rate"], row["mean_return"]))
        chosen[run.name] = {"chosen_episode": best["episode"], "models": rows}
        print(run.name)
        for row in rows:
            mark = " <- chosen" if row is best else ""
            print(f"  episode {row['episode']:4d}: 20 eps {row['validation_20']:.2f}, 30 more {row['validation_30']:.2f}, "
                  f"50 eps {row['success_rate']:.2f}, return {row['mean_return']:.2f}{mark}")
    (Path(__file__).parent / "validation.json").write_text(json.dumps(chosen, indent=1))


if __name__ == "__main__":
    main([Path(arg) for arg in sys.argv[1:]])
