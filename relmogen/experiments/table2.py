"""The paper's Tables II / A.4 (planner swap) and A.2 (arm collision checking) beside ours:
``relmogen report --table2 DIR --out OUT``.

``DIR`` holds a report per (task, algorithm), ``DIR/<Task>__<algorithm>/table.json`` (the Table I
folder). Every ReLMoGen policy there was trained with RRT-Connect for base and arm; the planner
table shows each evaluation with Lazy PRM swapped in for the base, the arm or both (arm collision
checking on), as a change from the training planners' row; the collision table shows evaluation
with arm collision checking off (as in training) against on. Only deterministic evaluations in the
task's first scene with the Fetch robot count; assisted rows are marked. ``OUT`` gets ``table.md``
and ``table.json``.
"""

from __future__ import annotations

import json
from pathlib import Path

from relmogen.experiments.report import TABLE_JSON_SCHEMA_VERSION, markdown_grid, summary_cell, training_of
from relmogen.experiments.table1 import metric_of, paper_order, read_tables
from relmogen.tasks import task_class

RELMOGEN = ("relmogen-r", "relmogen-d")
TRAINING_PLANNERS = ("rrt_connect", "rrt_connect")
PLANNER_PAIRS = (TRAINING_PLANNERS, ("rrt_connect", "lazy_prm"), ("lazy_prm", "rrt_connect"), ("lazy_prm", "lazy_prm"))
# The paper's Table II (PushDoorNav, ArrangeKitchenMM) and A.4, ReLMoGen-R: (base, arm) -> value
PAPER_PLANNER_SWAP = {
    "PushDoorNav": dict(zip(PLANNER_PAIRS, (0.99, 1.0, 0.99, 1.0))),
    "ArrangeKitchenMM": dict(zip(PLANNER_PAIRS, (5.25, 5.0, 5.18, 5.09))),
    "TabletopReachM": dict(zip(PLANNER_PAIRS[:2], (1.0, 1.0))),  # the arm only
    "InteractiveObstaclesNav": dict(zip(PLANNER_PAIRS, (0.91, 0.93, 0.91, 0.87))),
    "ArrangeChairMM": dict(zip(PLANNER_PAIRS, (0.34, 0.37, 0.35, 0.38))),
}
# The paper's Table A.2: algorithm -> task -> (checking off, checking on) at evaluation
PAPER_ARM_COLLISION = {
    "relmogen-r": {"PushDoorNav": (0.99, 0.99), "ButtonDoorNav": (0.91, 0.87), "InteractiveObstaclesNav": (0.95, 0.91),
                   "ArrangeKitchenMM": (5.22, 5.25), "ArrangeChairMM": (0.38, 0.34)},
    "relmogen-d": {"PushDoorNav": (0.85, 0.80), "ButtonDoorNav": (0.62, 0.66), "InteractiveObstaclesNav": (0.53, 0.60),
                   "ArrangeKitchenMM": (5.45, 5.72), "ArrangeChairMM": (0.30, 0.43)},
}
PLANNER_NAMES = {"rrt_connect": "RRT-Connect", "lazy_prm": "Lazy PRM"}

NOTE = """Ours: mean / std / max over seeds of the deterministic evaluation in the task's first scene
with Fetch, and the evaluation episodes per seed; every policy was trained with
RRT-Connect for base and arm. (change) is the difference of means from the first row of its group.
Paper: ReLMoGen-R's values in Tables II / A.4 and A.2 (A.2 from the best checkpoints); `-` where
the paper reports none, `not run` where we have no evaluation in that setting. A planner of a part
the task's subgoals never use (PointNav's arm, TabletopReachM's base) is not shown, and such a
task has no collision row."""


def evaluated_rows(folder: Path) -> list[dict]:
    """The ReLMoGen rows of ``folder/*/table.json`` in the planner and collision tables' setting
    (with the base goal rule the runs trained with)."""
    rows = []
    for source, table in read_tables(folder):
        reference = next((row for row in table["rows"] if row["reference"]), {})
        trained_goal, chosen = reference.get("base_goal"), reference.get("checkpoint") or "latest"
        rows += [dict(_with_defaults(row, source), reference_checkpoint=chosen) for row in table["rows"]
                 if row["algorithm"] in RELMOGEN and row["policy"] == "deterministic"
                 and row.get("robot") in (None, "fetch") and (row.get("scene") or "_A").endswith("_A")
                 and row.get("base_goal") in (None, trained_goal)]
    return rows


def _with_defaults(row: dict, source: str) -> dict:
    """Evaluations written before they recorded their planners used the training planners."""
    return dict(row, source=source, base_planner=row.get("base_planner") or TRAINING_PLANNERS[0],
                arm_planner=row.get("arm_planner") or TRAINING_PLANNERS[1])


def _setting(row: dict) -> tuple[str | None, str | None, bool | None]:
    """(base planner, arm planner, arm collision checking), None for what the task's subgoals never use."""
    task = row["task"]
    checking = bool(row["arm_collision"]) if _has_arm(task) else None
    return (*_used((row["base_planner"], row["arm_planner"]), task), checking)


def _has_arm(task: str) -> bool:
    return "arm" in task_class(task).subgoal_parts


def _groups(rows: list[dict]) -> dict[str, dict[tuple, dict]]:
    """source folder -> evaluation setting -> row (a row of the checkpoint its reference table
    evaluates, ``report --checkpoint``, wins over one of the other checkpoint)."""
    groups: dict[str, dict[tuple, dict]] = {}
    for row in sorted(rows, key=lambda r: r["checkpoint"] == r.get("reference_checkpoint", "latest")):
        groups.setdefault(row["source"], {})[_setting(row)] = row
    return groups


def _used(pair: tuple[str, str], task: str) -> tuple[str | None, str | None]:
    """The (base, arm) planner pair with None for a part the task's subgoals never use."""
    parts = task_class(task).subgoal_parts
    return (pair[0] if "base" in parts else None, pair[1] if "arm" in parts else None)


def _change(row: dict | None, reference: dict | None, metric: str) -> float | None:
    if row is None or reference is None or row.get(metric) is None or reference.get(metric) is None:
        return None
    return row[metric]["mean"] - reference[metric]["mean"]


def _entry(table: str, row: dict | None, reference: dict | None, setting: tuple, first: dict, paper,
           paper_reference) -> dict:
    metric = metric_of(first["task"])[0]
    return {
        "table": table, "task": first["task"], "algorithm": first["algorithm"], "source": first["source"],
        "assisted": first["assisted"], "base_planner": setting[0], "arm_planner": setting[1],
        "arm_collision": setting[2], "metric": metric,
        "seeds": None if row is None else row["seeds"], "eval_episodes": None if row is None else row["eval_episodes"],
        "ours": None if row is None else row.get(metric), "change": _change(row, reference, metric),
        "paper": paper,
        "paper_change": None if paper is None or paper_reference is None else round(paper - paper_reference, 4),
    }


def table2_entries(rows: list[dict]) -> list[dict]:
    """A planner-swap entry per planner pair and a collision entry per checking setting, for
    every Table I folder with a ReLMoGen evaluation in the training planners' setting."""
    entries = []
    for source, settings in sorted(_groups(rows).items(), key=lambda item: paper_order(next(iter(item[1].values())))):
        first = next(iter(settings.values()))
        task, algo = first["task"], first["algorithm"]
        checking = True if _has_arm(task) else None
        training = _used(TRAINING_PLANNERS, task)
        reference = settings.get((*training, checking))
        if reference is None:
            continue
        paper_swap = PAPER_PLANNER_SWAP.get(task, {}) if algo == "relmogen-r" else {}
        for pair in dict.fromkeys(_used(pair, task) for pair in PLANNER_PAIRS):  # distinct, in order
            base = pair != training  # the first row is the base of the changes
            entries.append(_entry("planner_swap", settings.get((*pair, checking)), reference if base else None,
                                  (*pair, checking), first, _paper_swap(paper_swap, pair),
                                  _paper_swap(paper_swap, training) if base else None))
        if checking is None:
            continue
        paper_off, paper_on = PAPER_ARM_COLLISION.get(algo, {}).get(task, (None, None))
        off = settings.get((*training, False))
        entries.append(_entry("arm_collision", off, None, (*training, False), first, paper_off, None))
        entries.append(_entry("arm_collision", reference, off, (*training, True), first, paper_on, paper_off))
    return entries


def _paper_swap(values: dict, pair: tuple[str | None, str | None]) -> float | None:
    """The paper's value for a planner pair; a part the task never uses matches any planner."""
    matches = [value for (base, arm), value in values.items()
               if pair[0] in (None, base) and pair[1] in (None, arm)]
    return matches[0] if matches else None


def _value_cell(value, change) -> str:
    if value is None:
        return "-"
    shown = summary_cell(value) if isinstance(value, dict) else f"{value:.2f}"
    return shown if change is None else f"{shown} ({change:+.2f})"


def _ours_cell(entry: dict) -> str:
    if entry["ours"] is None:
        return "not run"
    return f"{_value_cell(entry['ours'], entry['change'])}, {entry['eval_episodes']} eps"


def _lines(entries: list[dict], table: str, setting_cells) -> list[list[str]]:
    return [[e["task"], e["algorithm"], training_of(e), e["source"], metric_of(e["task"])[1], *setting_cells(e),
             _ours_cell(e), _value_cell(e["paper"], e["paper_change"])] for e in entries if e["table"] == table]


def table2_markdown(entries: list[dict]) -> str:
    common = ["task", "algorithm", "training", "folder", "metric"]
    planners = markdown_grid(common + ["base MP", "arm MP", "ours (change)", "paper (change)"],
                             _lines(entries, "planner_swap",
                                    lambda e: [PLANNER_NAMES.get(e["base_planner"], "(no base subgoals)"),
                                               PLANNER_NAMES.get(e["arm_planner"], "(no arm subgoals)")]))
    checking = markdown_grid(common + ["arm collision checking at evaluation", "ours (change)", "paper (change)"],
                             _lines(entries, "arm_collision",
                                    lambda e: ["on (the paper's Eval)" if e["arm_collision"] else "off, as in training"]))
    return "\n\n".join(["# Tables II, A.4 and A.2: our ReLMoGen policies beside the paper", NOTE,
                        "## Planner swap at test time (Tables II and A.4; arm collision checking on)", planners,
                        "## Arm collision checking at evaluation (Table A.2; RRT-Connect for base and arm)",
                        checking]) + "\n"


def write_table2(folder: Path, out: Path) -> dict:
    """Writes ``out/table.md`` and ``out/table.json`` from ``folder/*/table.json``; returns the json."""
    entries = table2_entries(evaluated_rows(folder))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    result = {"schema_version": TABLE_JSON_SCHEMA_VERSION, "source": str(folder), "rows": entries}
    (out / "table.json").write_text(json.dumps(result, indent=1))
    (out / "table.md").write_text(table2_markdown(entries))
    return result
