"""The paper's Table I beside ours: ``relmogen report --table1 DIR``.

``DIR`` holds a report per (task, algorithm), ``DIR/<Task>__<algorithm>/table.json`` (written by
``relmogen report``); ``DIR/README.md`` gets the comparison. Only reference rows of reward-only
runs are comparable with the paper: deterministic policy, arm collision checking on and the
planners used in training, with neither demonstrations nor oracle labels. Assisted runs are
listed in a table of their own.
"""

from __future__ import annotations

import json
from pathlib import Path

from relmogen.experiments.report import (FINAL_FRACTIONS, TABLE_JSON_SCHEMA_VERSION, fraction_label, hours_cell,
                                         markdown_grid, seeds_cell, summary_cell, training_of, updates_cell)

TASKS = ("PointNav", "TabletopReachM", "PushDoorNav", "ButtonDoorNav", "InteractiveObstaclesNav",
         "ArrangeKitchenMM", "ArrangeChairMM")
ALGORITHMS = ("relmogen-r", "relmogen-d", "sac", "oac", "hrl4in")
PAPER_METRIC = {  # task -> (key in table.json, label)
    "PointNav": ("success_rate", "SR"),
    "TabletopReachM": ("success_rate", "SR"),
    "PushDoorNav": ("success_rate", "SR"),
    "ButtonDoorNav": ("success_rate", "SR"),
    "InteractiveObstaclesNav": ("success_rate", "SR"),
    "ArrangeKitchenMM": ("closed_10", "closed (10 deg / 10 cm)"),
    "ArrangeChairMM": ("closed_10", "closed (10 cm)"),
}
PAPER_VALUES = {  # task -> algorithm -> the paper's mean over 3 seeds
    task: dict(zip(ALGORITHMS, values)) for task, values in {
        "PointNav": (0.72, 0.68, 0.60, 0.46, 0.33),
        "TabletopReachM": (1.0, 0.95, 1.0, 1.0, 0.09),
        "PushDoorNav": (0.97, 0.41, 0.0, 0.0, 0.0),
        "ButtonDoorNav": (0.73, 0.50, 0.01, 0.01, 0.0),
        "InteractiveObstaclesNav": (0.79, 0.58, 0.51, 0.01, 0.0),
        "ArrangeKitchenMM": (4.91, 6.10, 4.95, 3.55, 4.67),
        "ArrangeChairMM": (0.11, 0.36, 0.0, 0.0, 0.0),
    }.items()
}

HEADER = """# Table I: our runs beside the paper

Our reward-only runs (neither demonstrations nor oracle labels; 3 seeds each) against the paper's
Table I (its mean over 3 seeds). Ours is mean / std / max over seeds (their number in parentheses)
of the final evaluation: deterministic policy, arm collision checking on, the planners used in
training, 50-100 episodes (each folder's `table.md` gives `eval_episodes`) on evaluation seeds
from 100000. It evaluates each run's latest checkpoint,
except where a cell says "best checkpoint": there it evaluates the model that the run's periodic
evaluations (episodes on other seeds, below 100000; the folder's COMMANDS.md says which) chose
during training, an early-stopping protocol. Each `<Task>__<algorithm>/` folder holds its report
(`table.md`, `table.json`, `curves.png`) and the commands that made it (`COMMANDS.md`);
`relmogen report --table1 <this folder>` rewrites this file."""

ASSISTED_TITLE = "## Assisted runs: demonstrations or oracle labels; not comparable to the paper's reward-only numbers"


def read_tables(folder: Path) -> list[tuple[str, dict]]:
    """``(folder name, table)`` of every ``folder/*/table.json``, each checked for today's schema."""
    paths = sorted(Path(folder).glob("*/table.json"))
    if not paths:
        raise ValueError(f"no */table.json under {folder} "
                         f"(write them with `relmogen report RUN_DIR... --out {folder}/<Task>__<algo>`)")
    tables = []
    for path in paths:
        table = json.loads(path.read_text())
        if table.get("schema_version") != TABLE_JSON_SCHEMA_VERSION:
            raise ValueError(f"{path}: schema_version {table.get('schema_version')}, "
                             f"expected {TABLE_JSON_SCHEMA_VERSION}")
        tables.append((path.parent.name, table))
    return tables


def read_rows(folder: Path) -> list[dict]:
    """The reference rows of every ``folder/*/table.json``, each with its folder's name as ``source``."""
    return [dict(row, source=source) for source, table in read_tables(folder) for row in table["rows"]
            if row["reference"]]


def is_paper_setting(row: dict) -> bool:
    """Whether a reference row was evaluated as the paper's Table I: deterministic, arm collision on."""
    return row["policy"] == "deterministic" and row["arm_collision"] is True


def comparable_rows(rows: list[dict]) -> dict[tuple[str, str], dict]:
    """(task, algorithm) -> its reward-only row in the paper's setting; two for one pair is an error."""
    cells: dict[tuple[str, str], dict] = {}
    for row in rows:
        if row["assisted"] or not is_paper_setting(row):
            continue
        key = (row["task"], row["algorithm"])
        if key in cells:
            raise ValueError(f"two reward-only rows for {key[0]} {key[1]}: {cells[key]['source']} and {row['source']}")
        cells[key] = row
    return cells


def ours_cell(row: dict | None, metric: str) -> str:
    """``mean / std / max (seeds)`` of the row's metric; ``-`` without a row or a value."""
    summary = row.get(metric) if row is not None else None
    if summary is None:
        return "-"
    chosen = ", best checkpoint" if row.get("checkpoint") == "best" else ""
    return f"{summary_cell(summary)} ({row['seeds']}{chosen})"


def paper_cell(task: str, algo: str) -> str:
    """The paper's value for the task and algorithm; ``-`` where it reports none."""
    value = PAPER_VALUES.get(task, {}).get(algo)
    return "-" if value is None else f"{value:.2f}"


def metric_of(task: str) -> tuple[str, str]:
    """The ``table.json`` key and the label of the task's paper metric (success rate for other tasks)."""
    return PAPER_METRIC.get(task, ("success_rate", "SR"))


def catalogue_position(names: tuple[str, ...], name: str) -> int:
    """Where the name stands among the paper's names; after them all when it is not one."""
    return names.index(name) if name in names else len(names)


def paper_order(row: dict) -> tuple:
    """A sort key: the paper's task order, then its algorithm order, then the source folder."""
    return (catalogue_position(TASKS, row["task"]), row["task"], catalogue_position(ALGORITHMS, row["algorithm"]),
            row["algorithm"], row["source"])


def _task_line(task: str, comparable: dict[tuple[str, str], dict]) -> list[str]:
    """The task's cells of the main table: its metric, then per algorithm ours and the paper's."""
    metric, label = metric_of(task)
    line = [task, label]
    for algo in ALGORITHMS:
        line += [ours_cell(comparable.get((task, algo)), metric), paper_cell(task, algo)]
    return line


def main_table(rows: list[dict]) -> str:
    """A line per paper task: its metric and, per algorithm, ours beside the paper's."""
    comparable = comparable_rows(rows)
    header = ["task", "metric"] + [f"{algo} {side}" for algo in ALGORITHMS for side in ("ours", "paper")]
    return markdown_grid(header, [_task_line(task, comparable) for task in TASKS])


def assisted_table(rows: list[dict]) -> str:
    """A line per assisted reference row: ours on the task's metric beside the paper's reward-only value."""
    header = ["task", "algorithm", "folder", "metric", "ours", "paper (reward-only)"]
    lines = [[row["task"], row["algorithm"], row["source"], metric_of(row["task"])[1],
              ours_cell(row, metric_of(row["task"])[0]), paper_cell(row["task"], row["algorithm"])]
             for row in sorted(rows, key=paper_order) if row["assisted"] and is_paper_setting(row)]
    return markdown_grid(header, lines)


def budget_table(rows: list[dict]) -> str:
    """A line per reference row: the training budget, episodes and CPU hours, as means over seeds,
    and per seed the episodes at which its periodic evaluation first reached half and 90% of its
    final figure (``report.episodes_to_fraction_of_final``; ``-`` for reports written before it)."""
    header = ["task", "algorithm", "training", "folder", "seeds", "episodes", "gradient updates", "CPU h",
              *(f"{fraction_label(fraction)}, per seed" for fraction in FINAL_FRACTIONS)]
    lines = [[row["task"], row["algorithm"], training_of(row), row["source"], str(row["seeds"]),
              str(int(row["episodes"])), updates_cell(row), hours_cell(row["cpu_hours"]),
              *(fraction_cell(row, fraction) for fraction in FINAL_FRACTIONS)] for row in sorted(rows, key=paper_order)]
    return markdown_grid(header, lines)


def fraction_cell(row: dict, fraction: float) -> str:
    milestones = row.get("episodes_to_final_fraction")
    return seeds_cell(milestones[f"{fraction:g}"]) if milestones else "-"


RERUNS_TITLE = """## Reruns from the recipes

`relmogen reproduce <Task>__<algo> --publish` of a cell that already holds a figure puts the rerun
in `<Task>__<algo>/reruns/<commit>-<host kind>/` (report, run folders, `rerun.json`); each line
sets its figure beside the cell's. CPU h per seed depend on the host kind (docs/benchmarks.md)."""


def read_reruns(folder: Path) -> list[dict]:
    """Every ``folder/<cell>/reruns/<label>/``'s reference row, with its cell, label and host."""
    reruns = []
    for path in sorted(Path(folder).glob("*/reruns/*/table.json")):
        record = json.loads((path.parent / "rerun.json").read_text())
        for row in json.loads(path.read_text())["rows"]:
            if row["reference"]:
                reruns.append(dict(row, source=path.parents[2].name, label=path.parent.name,
                                   host=host_label(record.get("host") or {}),
                                   commit=record["recipe"].get("commit")))
    return reruns


def host_label(host: dict) -> str:
    """"AMD EPYC (avx512)": the CPU model and the host kind, which decides the CPU hours."""
    model = host.get("cpu_model", "unknown")
    return f"{model} ({host['host_kind']})" if host.get("host_kind") else model


def reruns_table(rows: list[dict], reruns: list[dict]) -> str:
    """A line per rerun: the metric of the cell's own row beside the rerun's, its host and budget."""
    committed = {row["source"]: row for row in rows}
    header = ["cell", "metric", "the cell", "rerun", "commit", "host", "episodes", "CPU h"]
    lines = []
    for rerun in sorted(reruns, key=paper_order):
        metric, label = metric_of(rerun["task"])
        lines.append([rerun["source"], label, ours_cell(committed.get(rerun["source"]), metric),
                      ours_cell(rerun, metric), str(rerun["commit"]), rerun["host"], str(int(rerun["episodes"])),
                      hours_cell(rerun["cpu_hours"])])
    return markdown_grid(header, lines)


def table1_markdown(rows: list[dict], reruns: list[dict] = ()) -> str:
    """The README: header, the comparison, the assisted runs, the training budgets and the reruns."""
    parts = [HEADER, main_table(rows), ASSISTED_TITLE, assisted_table(rows),
             "## Training budget (means over seeds; CPU h counts trainer and environment workers)",
             budget_table(rows)]
    if reruns:
        parts += [RERUNS_TITLE, reruns_table(rows, list(reruns))]
    return "\n\n".join(parts) + "\n"


def write_table1(folder: Path) -> Path:
    """Writes ``folder/README.md`` from ``folder/*/table.json`` and the reruns; returns its path."""
    readme = Path(folder) / "README.md"
    readme.write_text(table1_markdown(read_rows(folder), read_reruns(folder)))
    return readme
