"""Where SGP-D policies rank the cell the oracle pushes, per task and training stage.

Reads the ``oracle_cells.json`` that ``relmogen viz qmap RUN --drive oracle --out DIR/RUN``
writes, for folders named ``<task>__relmogen-d__<seed>__...`` under each STAGE folder, and
prints one markdown row per stage and task: the mean percentile of the oracle's cell in the
learned arm Q map (mean / std / max over seeds; 50 is what an uninformative map gives on
average), the same for the 3x3 cells around it (among all such squares), and how often the
greedy choice was an arm action, or the oracle's very cell.

    python results/sgpd-long/oracle_cell_table.py results/sgpd-long/oracle_qmaps/{untrained,1.75h,3.5h}
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

from relmogen.experiments.report import summarise


def stage_rows(stage: Path) -> dict[str, list[dict]]:
    by_task: dict[str, list[dict]] = defaultdict(list)
    for summary in sorted(stage.glob("*/oracle_cells.json")):
        by_task[summary.parent.name.split("__")[0]].append(json.loads(summary.read_text()))
    return by_task


def area_column(seeds: list[dict]) -> str:
    """Mean / std / max of the 3x3 area percentile; "-" for summaries written before it existed."""
    if any(s.get("mean_area_percentile") is None for s in seeds):
        return "-"
    area = summarise([s["mean_area_percentile"] for s in seeds])
    return f"{area['mean']:.1f} / {area['std']:.1f} / {area['max']:.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("stages", nargs="+", type=Path)
    args = parser.parse_args()
    print("| stage | task | seeds | states per seed | oracle cell percentile (mean / std / max) "
          "| 3x3 area percentile | greedy chose arm | greedy chose the oracle's cell |")
    print("|---|---|---|---|---|---|---|---|")
    for stage in args.stages:
        by_task = stage_rows(stage)
        if not by_task:
            raise SystemExit(f"no */oracle_cells.json under {stage}")
        for task, seeds in sorted(by_task.items()):
            percentile = summarise([s["mean_percentile"] for s in seeds])
            states = sum(s["pushes"] for s in seeds)
            print(f"| {stage.name} | {task} | {len(seeds)} | {states // len(seeds)} "
                  f"| {percentile['mean']:.1f} / {percentile['std']:.1f} / {percentile['max']:.1f} "
                  f"| {area_column(seeds)} "
                  f"| {sum(s['greedy_arm'] for s in seeds)} of {states} "
                  f"| {sum(s['greedy_is_oracle_cell'] for s in seeds)} of {states} |")


if __name__ == "__main__":
    main()
