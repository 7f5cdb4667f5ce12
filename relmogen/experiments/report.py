"""``relmogen report``: the paper's table (mean / std / max over seeds) and training curves.

Each run directory contributes its final evaluation (the newest ``eval/*.json`` of its latest
checkpoint with arm collision checking on, else the last periodic evaluation) and its
``episodes.csv`` curve. Curves are averaged over seeds on a common grid of environment episodes
(the paper's x-axis); a panel without data says so. Tables show a task's own metrics only
(``relmogen.experiments.task_catalogue``): ``n/a`` marks a metric another task in the same table
has, and a run without any evaluation gets a line saying how to make one.

``table.json`` holds the rows of ``table.md`` (the reference table, then every evaluation
setting) as data, for ``relmogen.experiments.table1`` to gather into the paper's Table I.
"""

from __future__ import annotations

import csv
import json
import warnings
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from relmogen.experiments.budgets import gradient_updates  # noqa: E402
from relmogen.experiments.config import read_config  # noqa: E402
from relmogen.experiments.finetune import read_init_from  # noqa: E402
from relmogen.experiments.task_catalogue import task_evaluation_keys  # noqa: E402

TABLE_METRICS = ("success_rate", "spl", "closed_5", "closed_10")  # every evaluation has them, 0 if not the task's
CURVE_SMOOTHING = 20  # episodes in the moving average of each seed's curve
CURVES_DPI = 100


def policy_of(evaluation: dict) -> str:
    """How actions were chosen; evaluations written before the field existed were deterministic."""
    return evaluation.get("policy", "deterministic")


REFERENCE_CHECKPOINTS = ("latest", "best")


def checkpoint_of(evaluation: dict) -> str:
    """``best`` for an evaluation of ``checkpoints/best``, ``evaluated`` for one of a model kept by
    ``run.keep_evaluated``, else ``latest`` (any other checkpoint folder: the run's latest unless
    chosen by path; evaluations older than the field)."""
    name = str(evaluation.get("checkpoint", ""))
    return "best" if name.startswith("best_") else "evaluated" if name.startswith("evaluated_") else "latest"


def has_metric(task: str, metric: str) -> bool:
    """Whether ``metric`` belongs in ``task``'s rows: not one of ``TABLE_METRICS`` that the task
    lacks (no ``closed_*`` for PointNav, no ``spl`` for ArrangeKitchenMM)."""
    return metric not in TABLE_METRICS or metric in task_evaluation_keys(task)


def final_evaluation(run_dir: Path, checkpoint: str = "latest") -> dict | None:
    """The run's reference evaluation of its ``checkpoint`` (``latest``, or ``best``: the model
    its periodic evaluations chose): arm collision checking on, with the planners it was
    trained with, of the newest checkpoint evaluated (a run continued to more episodes keeps its
    earlier evaluations), the most episodes, then the newest (planner-swap and scene-transfer
    evaluations sit beside it and are reported separately); else, for ``latest``, the last
    periodic one."""
    if checkpoint not in REFERENCE_CHECKPOINTS:
        raise ValueError(f"reference checkpoint {checkpoint!r}; valid: {', '.join(REFERENCE_CHECKPOINTS)}")
    config = read_config(run_dir / "config.yaml")
    evals = [read_evaluation(p) | {"_mtime": p.stat().st_mtime} for p in (run_dir / "eval").glob("*collision-on*.json")]
    evals = [e for e in evals if policy_of(e) == "deterministic" and checkpoint_of(e) == checkpoint]
    same_planners = [e for e in evals if e.get("base_planner", config.env.base_planner) == config.env.base_planner
                     and e.get("arm_planner", config.env.arm_planner) == config.env.arm_planner
                     and e.get("base_goal", config.env.base_goal) == config.env.base_goal
                     and e.get("base_goal_clearance", 0.0) == config.env.base_goal_clearance
                     and (config.env.scene is None or e.get("scene") == config.env.scene)
                     and e.get("robot", config.env.robot) == config.env.robot]
    if same_planners:
        best = max(same_planners, key=lambda e: (_checkpoint_episode(e), e.get("episodes", 0), e["_mtime"]))
        return {k: v for k, v in best.items() if k != "_mtime"}
    periodic = read_periodic_evaluations(run_dir) if checkpoint == "latest" else []
    return periodic[-1] if periodic else None


def _checkpoint_episode(evaluation: dict) -> int:
    """The training episode of the checkpoint an evaluation evaluated; -1 where it records none."""
    episode = evaluation.get("checkpoint_episode")
    return -1 if episode is None else episode


def evaluations_by_setting(run: dict) -> dict[tuple, list[dict]]:
    """A run's evaluations by setting (``evaluation_setting``), each setting's of its newest
    checkpoint only: an evaluation of an earlier checkpoint (say before the run was continued) is
    superseded, not another seed."""
    by_setting: dict[tuple, list[dict]] = defaultdict(list)
    for evaluation in run.get("all_evals", []):
        by_setting[tuple(evaluation_setting(evaluation).values())].append(evaluation)
    newest = {setting: max(map(_checkpoint_episode, found)) for setting, found in by_setting.items()}
    return {setting: [e for e in found if _checkpoint_episode(e) == newest[setting]]
            for setting, found in by_setting.items()}


def read_evaluation(path: Path) -> dict:
    """An ``eval/*.json`` file's fields, with ``arm_collision`` taken from the file name where
    the evaluation does not record it (joint-control evaluations)."""
    evaluation = json.loads(path.read_text())
    evaluation.setdefault("arm_collision", "collision-off" not in path.name)
    return evaluation


def checkpoint_evaluations(run_dir: Path, checkpoint_name: str) -> list[dict]:
    """The ``relmogen eval`` results saved in ``RUN/eval/`` for one checkpoint folder (e.g.
    ``best_0000500``), most episodes first."""
    evaluations = [read_evaluation(f) for f in sorted((Path(run_dir) / "eval").glob("*.json"))]
    mine = [e for e in evaluations if e.get("checkpoint") == checkpoint_name]
    return sorted(mine, key=lambda e: -e.get("episodes", 0))


def is_assisted(config) -> bool:
    """Whether the run learned from more than its reward: oracle demonstrations or oracle labels."""
    return config.algo_params.demo_episodes > 0 or config.oracle_labels


def summarise(values: list[float]) -> dict[str, float]:
    arr = np.asarray(values, dtype=float)
    return {"mean": float(arr.mean()), "std": float(arr.std()), "max": float(arr.max()), "n": len(arr)}


def collect(run_dirs: list[Path], checkpoint: str = "latest") -> dict[tuple[str, str], list[dict]]:
    from relmogen.experiments.checkpoints import run_config_file

    run_dirs = [Path(run_dir) for run_dir in run_dirs]
    for run_dir in run_dirs:
        run_config_file(run_dir)
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for run_dir in run_dirs:
        config = read_config(run_dir / "config.yaml")
        groups[(config.task, config.algo)].append({
            "seed": config.seed, "run_dir": run_dir, "eval": final_evaluation(run_dir, checkpoint), "assisted": is_assisted(config),
            "eval_every": config.run.eval_every_episodes,
            "all_evals": [read_evaluation(p) for p in sorted((run_dir / "eval").glob("*.json"))],
            "curve": read_curve(run_dir / "episodes.csv"), "state": (state := _state(run_dir)),
            "updates": gradient_updates(config, state),
            "periodic": read_periodic_evaluations(run_dir), "init": read_init_from(run_dir) or {},
        })
    return groups


def read_periodic_evaluations(run_dir: Path) -> list[dict]:
    """The evaluations made during training (``eval_during_training.jsonl``), in order."""
    path = run_dir / "eval_during_training.jsonl"
    lines = path.read_text().splitlines() if path.is_file() else []
    return [json.loads(line) for line in lines if line.strip()]


SR_MILESTONES = (0.5, 0.9)  # the training episodes at which periodic evaluation first reached these


def episodes_to_success_rate(periodic: list[dict], threshold: float) -> int | None:
    """The training episodes at the first periodic evaluation with success rate >= ``threshold``
    (None if none did). Those evaluations are short (``run.eval_episodes``), so this is a noisy
    first passage, not a converged figure."""
    return next((int(e["episode"]) for e in periodic if e.get("success_rate", 0.0) >= threshold), None)


def _milestones(runs: list[dict]) -> dict[str, list[int | None]]:
    """Per milestone of ``SR_MILESTONES`` (key ``"0.5"``...), each seed's ``episodes_to_success_rate``,
    counting the episodes behind a fine-tuned run's initial weights."""
    def reached(run: dict, threshold: float) -> int | None:
        return _counting_initial_episodes(run, episodes_to_success_rate(run.get("periodic", []), threshold))

    return {f"{threshold:g}": [reached(run, threshold) for run in runs] for threshold in SR_MILESTONES}


def _counting_initial_episodes(run: dict, episodes: int | None) -> int | None:
    """``episodes`` of a run plus those behind a fine-tuned run's initial weights; None stays None."""
    return None if episodes is None else episodes + int(run.get("init", {}).get("initial_episodes", 0))


FINAL_FRACTIONS = (0.5, 0.9)  # the training episodes at which periodic evaluation first reached these of the final figure


def headline_metric(task: str) -> str:
    """The evaluation key a task is judged by in Table I: items closed (``closed_10``) for the
    arrangement tasks, the success rate for the others (as ``table1.PAPER_METRIC``, which builds on
    this module)."""
    return "closed_10" if has_metric(task, "closed_10") else "success_rate"


def episodes_to_fraction_of_final(periodic: list[dict], metric: str, final: float | None,
                                  fraction: float) -> int | None:
    """The training episodes at the first periodic evaluation whose ``metric`` reached ``fraction``
    of ``final`` (the seed's final evaluation); None if none did, or if the final figure is not
    above 0 (then every evaluation "reaches" it and the episode says nothing)."""
    if final is None or final <= 0.0:
        return None
    return next((int(e["episode"]) for e in periodic if e.get(metric, 0.0) >= fraction * final), None)


def _final_fraction_milestones(task: str, runs: list[dict]) -> dict[str, list[int | None]]:
    """Per fraction of ``FINAL_FRACTIONS`` (key ``"0.5"``...), each seed's
    ``episodes_to_fraction_of_final`` on the task's ``headline_metric``, counting the episodes
    behind a fine-tuned run's initial weights."""
    metric = headline_metric(task)

    def reached(run: dict, fraction: float) -> int | None:
        final = (run.get("eval") or {}).get(metric)
        return _counting_initial_episodes(run, episodes_to_fraction_of_final(run.get("periodic", []), metric,
                                                                             final, fraction))

    return {f"{fraction:g}": [reached(run, fraction) for run in runs] for fraction in FINAL_FRACTIONS}


def _state(run_dir: Path) -> dict:
    """Budget spent: ``done.json`` of a finished run, else its latest checkpoint's state."""
    from relmogen.experiments.checkpoints import latest_checkpoint

    done = run_dir / "done.json"
    if done.is_file():
        return json.loads(done.read_text())
    checkpoint = latest_checkpoint(run_dir)
    return json.loads((checkpoint / "state.json").read_text()) if checkpoint is not None else {}


CURVE_KEYS = ("episode", "success", "return", "wall_time_s", "base_fraction", "closed_10")


def _number(text: str | None) -> float:
    return float(text) if text not in (None, "") else np.nan


def read_curve(path: Path) -> dict[str, np.ndarray]:
    """``episodes.csv`` columns as arrays; NaN where a row lacks a value (``base_fraction`` is
    logged for subgoal controls only, and not by runs older than that column)."""
    rows = []
    if path.is_file():
        with open(path, newline="") as handle:
            rows = list(csv.DictReader(handle))
    return {key: np.array([_number(r.get(key)) for r in rows]) for key in CURVE_KEYS}


SETTING_KEYS = ("scene", "robot", "base_planner", "arm_planner", "base_goal", "base_goal_clearance", "arm_collision",
                "policy", "checkpoint", "eval_episodes")
SETTING_METRICS = ("success_rate", "spl", "closed_10", "subgoal_success_rate", "base_fraction",
                   "repeated_subgoal_rate", "unchanged_view_rate", "oracle_agreement")
ROW_METRICS = TABLE_METRICS + tuple(metric for metric in SETTING_METRICS if metric not in TABLE_METRICS)
TABLE_JSON_SCHEMA_VERSION = 1


def evaluation_setting(evaluation: dict) -> dict:
    """The conditions an evaluation ran under, keyed as ``SETTING_KEYS``; None where it records none."""
    return {"scene": evaluation.get("scene"), "robot": evaluation.get("robot"),
            "base_planner": evaluation.get("base_planner"),
            "arm_planner": evaluation.get("arm_planner"), "base_goal": evaluation.get("base_goal"),
            "base_goal_clearance": evaluation.get("base_goal_clearance", 0.0 if evaluation.get("base_goal") else None),
            "arm_collision": evaluation.get("arm_collision", True),
            "policy": policy_of(evaluation), "checkpoint": checkpoint_of(evaluation),
            "eval_episodes": evaluation.get("episodes")}


def _shared_setting(evaluations: list[dict]) -> dict:
    """The setting the evaluations share, key by key; None where they differ or there are none."""
    settings = [evaluation_setting(evaluation) for evaluation in evaluations]
    return {key: settings[0][key] if settings and all(s[key] == settings[0][key] for s in settings) else None
            for key in SETTING_KEYS}


def _metric_summaries(task: str, evaluations: list[dict]) -> dict[str, dict | None]:
    """Per metric of ``ROW_METRICS``: mean / std / max over the evaluations reporting it; None
    when none does or the task has no such metric (``has_metric``)."""
    summaries = {}
    for metric in ROW_METRICS:
        values = [evaluation[metric] for evaluation in evaluations if metric in evaluation and has_metric(task, metric)]
        summary = summarise(values) if values else None
        summaries[metric] = {key: summary[key] for key in ("mean", "std", "max")} if summary else None
    return summaries


def _budget(runs: list[dict]) -> dict[str, float | None]:
    """Means over the runs of the training budget spent: episodes, wall-clock hours and CPU hours
    (trainer plus environment workers; None unless every run logged it). A run started with
    ``--init-from`` counts what its initial weights cost too; ``initial_episodes`` and
    ``initial_cpu_hours`` give that part alone (0 for runs from scratch)."""
    def initial(run: dict, key: str) -> float:
        return float(run["init"].get(f"initial_{key}", 0.0))

    episodes = [run["state"].get("episodes", len(run["curve"]["episode"])) + initial(run, "episodes") for run in runs]
    wall_hours = [(run["state"].get("wall_time_s", 0.0) + initial(run, "wall_time_s")) / 3600 for run in runs]
    cpu_hours = [(run["state"]["cpu_time_s"] + initial(run, "cpu_time_s")) / 3600
                 for run in runs if "cpu_time_s" in run["state"]]
    updates = [_gradient_updates_with_initial(run) for run in runs]
    return {"episodes": float(np.mean(episodes)), "wall_hours": float(np.mean(wall_hours)),
            "cpu_hours": float(np.mean(cpu_hours)) if len(cpu_hours) == len(runs) else None,
            "gradient_updates": float(np.mean(updates)) if runs and None not in updates else None,
            "gradient_updates_counted": all(run.get("updates", (None, False))[1] for run in runs),
            "initial_episodes": float(np.mean([initial(run, "episodes") for run in runs])),
            "initial_cpu_hours": float(np.mean([initial(run, "cpu_time_s") for run in runs])) / 3600}


def _gradient_updates_with_initial(run: dict) -> int | None:
    """The run's gradient steps plus those behind its ``--init-from`` weights (None where either is
    unknown: HRL4IN runs and fine-tuned runs from before the count)."""
    updates, _ = run.get("updates", (None, False))
    if updates is None or not run["init"]:
        return updates
    initial = run["init"].get("initial_gradient_updates")
    return None if initial is None else updates + int(initial)


def updates_cell(row: dict) -> str:
    """Mean gradient updates per run; ``~`` marks a figure derived from the runs' update schedule
    (runs from before the count), ``-`` an unknown one."""
    updates = row.get("gradient_updates")
    if updates is None:
        return "-"
    return f"{'' if row.get('gradient_updates_counted') else '~'}{updates:,.0f}"


def _row(task: str, algo: str, reference: bool, runs: list[dict], evaluations: list[dict], setting: dict) -> dict:
    """One table row: its setting, seed count, assisted flag, training budget and metric summaries."""
    return {"task": task, "algorithm": algo, "reference": reference, **setting, "seeds": len(runs),
            "assisted": any(run.get("assisted", False) for run in runs), **_budget(runs),
            **_metric_summaries(task, evaluations)}


def reference_rows(groups: dict[tuple[str, str], list[dict]]) -> list[dict]:
    """A row per (task, algorithm) over each seed's reference evaluation (``final_evaluation``)."""
    rows = []
    for (task, algo), runs in sorted(groups.items()):
        evaluations = [run["eval"] for run in runs if run["eval"] is not None]
        row = _row(task, algo, True, runs, evaluations, _shared_setting(evaluations))
        rows.append(row | {"episodes_to_success_rate": _milestones(runs),
                           "episodes_to_final_fraction": _final_fraction_milestones(task, runs)})
    return rows


def setting_rows(groups: dict[tuple[str, str], list[dict]]) -> list[dict]:
    """A row per (task, algorithm, evaluation setting) found among the runs' ``eval/*.json``:
    planner swaps, scene transfer, collision off, policies and episode counts."""
    rows = []
    for (task, algo), runs in sorted(groups.items()):
        by_setting: dict[tuple, list[tuple[dict, dict]]] = defaultdict(list)
        for run in runs:
            for setting, evaluations in evaluations_by_setting(run).items():
                by_setting[setting] += [(run, evaluation) for evaluation in evaluations]
        for setting in sorted(by_setting, key=lambda values: [text_cell(value) for value in values]):
            pairs = by_setting[setting]
            evaluated = list({str(run["run_dir"]): run for run, _ in pairs}.values())
            rows.append(_row(task, algo, False, evaluated, [e for _, e in pairs], dict(zip(SETTING_KEYS, setting))))
    return rows


def table_json(rows: list[dict]) -> dict:
    """``table.json``: ``schema_version`` and ``rows``, those of ``table.md`` in its order. A row has
    ``task``, ``algorithm``, ``reference`` (true: the reference table, each seed's ``final_evaluation``;
    false: one evaluation setting), the setting (``SETTING_KEYS``; null where the evaluations disagree or
    do not record it), ``seeds``, ``assisted``, the mean training budget (``episodes``, ``wall_hours``,
    ``cpu_hours``) and per metric of ``ROW_METRICS`` ``{mean, std, max}`` over seeds, or null. Reference
    rows also have ``episodes_to_success_rate``: per milestone (``"0.5"``, ``"0.9"``) a list with each
    seed's training episodes at its first periodic evaluation that reached it (null if none), and
    ``episodes_to_final_fraction``: the same per fraction (``"0.5"``, ``"0.9"``) of each seed's own final
    figure on the task's ``headline_metric``."""
    return {"schema_version": TABLE_JSON_SCHEMA_VERSION, "rows": rows}


def text_cell(value) -> str:
    """A markdown cell for a plain value: ``-`` for None."""
    return "-" if value is None else str(value)


def summary_cell(summary: dict | None) -> str:
    """A markdown cell ``mean / std / max`` for a metric summary: ``-`` for None."""
    return "-" if summary is None else f"{summary['mean']:.2f} / {summary['std']:.2f} / {summary['max']:.2f}"


def metric_cell(row: dict, metric: str) -> str:
    """``summary_cell`` of a row's metric, ``n/a`` where its task has no such metric."""
    return summary_cell(row[metric]) if has_metric(row["task"], metric) else "n/a"


def shown_metrics(rows: list[dict], metrics: tuple[str, ...]) -> list[str]:
    """The ``metrics`` some row's task has: the columns of a table of ``rows``."""
    tasks = {row["task"] for row in rows}
    return [metric for metric in metrics if any(has_metric(task, metric) for task in tasks)]


def hours_cell(hours: float | None) -> str:
    """A markdown cell for hours: two decimals, ``-`` for None."""
    return "-" if hours is None else f"{hours:.2f}"


def training_of(row: dict) -> str:
    """``assisted`` for a row with demonstrations or oracle labels, else ``reward-only``."""
    return "assisted" if row["assisted"] else "reward-only"


def markdown_grid(header: list[str], lines: list[list[str]]) -> str:
    """A markdown table with the header and a line per list of cells."""
    return "\n".join(["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
                     + ["| " + " | ".join(cells) + " |" for cells in lines])


def reference_table(rows: list[dict]) -> str:
    """The markdown table of the reference rows, with a note on what the cells are."""
    metrics = shown_metrics(rows, TABLE_METRICS)
    milestones = [f"episodes to SR {threshold:g}" for threshold in SR_MILESTONES]
    fractions = [fraction_label(fraction) for fraction in FINAL_FRACTIONS]
    header = ["task", "algorithm", "training", "seeds", *metrics, "episodes", "gradient updates", "wall-clock h", "CPU h",
              *milestones, *fractions]
    lines = [[row["task"], row["algorithm"], training_of(row), str(row["seeds"]),
              *(metric_cell(row, metric) for metric in metrics),
              str(int(row["episodes"])), updates_cell(row), hours_cell(row["wall_hours"]), hours_cell(row["cpu_hours"]),
              *(seeds_cell(row["episodes_to_success_rate"][f"{t:g}"]) for t in SR_MILESTONES),
              *(seeds_cell(row["episodes_to_final_fraction"][f"{f:g}"]) for f in FINAL_FRACTIONS)] for row in rows]
    return (markdown_grid(header, lines) + "\n\nCells are mean / std / max over seeds of the final evaluation "
            "(deterministic policy). episodes, gradient updates, wall-clock h and CPU h (trainer plus environment "
            "workers) are means over seeds; ~ marks updates derived from the runs' update schedule (runs from before "
            "they were counted). training: assisted where a run used oracle demonstrations or oracle labels. episodes to "
            "SR x: per seed, the training episodes at the first periodic evaluation (a few episodes, as during "
            "training) with success rate at least x; - if none. episodes to x% of final: the same, for x% of the seed's "
            "own final figure (items closed on the arrangement tasks, else the success rate); - if none or if the "
            "final figure is 0.")


def fraction_label(fraction: float) -> str:
    return f"episodes to {fraction:.0%} of final"


def seeds_cell(values: list) -> str:
    """A markdown cell listing one value per seed, ``-`` for None."""
    return ", ".join(text_cell(value) for value in values) or "-"


def settings_table(rows: list[dict]) -> str:
    """The markdown table of the evaluation-setting rows: mean / std / max over the seeds
    evaluated with each setting."""
    metrics = shown_metrics(rows, SETTING_METRICS)
    header = ["task", "algorithm", "training", *SETTING_KEYS, "seeds", *metrics]
    lines = [[row["task"], row["algorithm"], training_of(row), *(text_cell(row[key]) for key in SETTING_KEYS),
              str(row["seeds"]), *(metric_cell(row, metric) for metric in metrics)] for row in rows]
    return markdown_grid(header, lines)


def missing_evaluation_hints(groups: dict[tuple[str, str], list[dict]]) -> list[str]:
    """A line per run without any evaluation, saying how to make one."""
    return [f"- {run['run_dir']} has no evaluation yet: run `relmogen eval {run['run_dir']}` (training also "
            f"evaluates every {run['eval_every']} episodes)"
            for _, runs in sorted(groups.items()) for run in runs if run["eval"] is None]


def trailing_mean(values: np.ndarray, window: int) -> np.ndarray:
    """Each value's mean with up to ``window - 1`` values before it, NaN ones left out (NaN
    where all of them are NaN)."""
    finite = np.isfinite(values)
    sums = np.concatenate([[0.0], np.cumsum(np.where(finite, values, 0.0))])
    counts = np.concatenate([[0], np.cumsum(finite)])
    end = np.arange(1, len(values) + 1)
    start = np.maximum(end - window, 0)
    total, count = sums[end] - sums[start], counts[end] - counts[start]
    return np.divide(total, count, out=np.full(len(values), np.nan), where=count > 0)


def _smoothed_on_grid(curve: dict, key: str, grid: np.ndarray, window: int = CURVE_SMOOTHING) -> np.ndarray:
    smooth = trailing_mean(curve[key], window)
    known = np.isfinite(smooth) & np.isfinite(curve["episode"])
    if not known.any():
        return np.full(len(grid), np.nan)
    return np.interp(grid, curve["episode"][known], smooth[known], left=np.nan, right=np.nan)


@dataclass(frozen=True)
class Panel:
    """One row of ``curves.png``: an ``episodes.csv`` column against episodes or hours, with the
    field of the periodic evaluations drawn as points over it (None: no points)."""

    key: str
    axis_key: str
    ylabel: str
    xlabel: str
    evaluation_key: str | None
    descriptive: bool = False  # not an outcome: left out where it cannot vary (PointNav's base share is 1)


ROLLING = f"rolling mean of {CURVE_SMOOTHING} episodes"
PANELS = (Panel("success", "episode", f"success rate of training episodes\n({ROLLING})", "training episodes",
                "success_rate"),
          Panel("return", "episode", f"episode return\n(training: {ROLLING})", "training episodes", "mean_return"),
          Panel("return", "hours", f"episode return\n(training: {ROLLING})", "wall-clock hours", "mean_return"),
          Panel("base_fraction", "episode", f"base share of subgoals\n(training: {ROLLING})", "training episodes",
                None, descriptive=True))
ITEMS_PANEL = Panel("closed_10", "episode", f"items closed per training episode\n(10 deg / 10 cm; {ROLLING})",
                    "training episodes", "closed_10")


def mean_and_std(runs: list[dict], key: str, axis_key: str,
                  window: int = CURVE_SMOOTHING) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seed mean and std of the ``key`` smoothed over ``window`` episodes (``trailing_mean``) on a
    common grid of episodes or hours."""
    curves = [dict(r["curve"], hours=r["curve"]["wall_time_s"] / 3600) for r in runs]
    last = max(c[axis_key].max(initial=0) for c in curves)
    start = 1.0 if axis_key == "episode" else 0.0
    grid = np.linspace(start, max(last, start + 1e-6), 200)
    values = np.array([_smoothed_on_grid(dict(c, episode=c[axis_key]), key, grid, window) for c in curves])
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # grid points no seed reached yet
        return grid, np.nanmean(values, axis=0), np.nanstd(values, axis=0)


def _counts_items(runs: list[dict]) -> bool:
    """Runs of a task scored by items closed (logged per episode since that column exists)."""
    return any(np.isfinite(r["curve"]["closed_10"]).any() for r in runs)


def seeds_text(count: int) -> str:
    return "1 seed" if count == 1 else f"mean and std of {count} seeds"


def evaluation_label(algo: str, runs: list[dict]) -> str:
    """Legend text of a group's periodic evaluations, with their episodes when all agree."""
    sizes = {e.get("episodes") for run in runs for e in run["periodic"]}
    each = f" of {sizes.pop()} episodes" if len(sizes) == 1 and None not in sizes else ""
    return f"{algo}, periodic evaluations{each} (greedy, one point per seed)"


def evaluation_points(runs: list[dict], panel: Panel) -> np.ndarray:
    """(n, 2) x, y of every seed's periodic evaluations that record ``panel.evaluation_key``."""
    scale = 3600.0 if panel.axis_key == "hours" else 1.0
    x_field = "wall_time_s" if panel.axis_key == "hours" else "episode"
    points = [(e[x_field] / scale, e[panel.evaluation_key]) for run in runs for e in run["periodic"]
              if e.get(x_field) is not None and e.get(panel.evaluation_key) is not None]
    return np.array(points, dtype=float).reshape(-1, 2)


def logged_values(runs: list[dict], key: str) -> np.ndarray:
    values = np.concatenate([r["curve"][key] for r in runs]) if runs else np.array([])
    return values[np.isfinite(values)]


def skip_note(runs: list[dict], panel: Panel) -> str | None:
    """Why a descriptive panel is left out for these runs (None: it is drawn): nothing logged,
    or one value throughout, which says nothing about training."""
    if not panel.descriptive:
        return None
    values = logged_values(runs, panel.key)
    if values.size == 0:
        return f"{panel.ylabel.splitlines()[0]}: not logged\n(joint-velocity runs)"
    if np.ptp(values) == 0:
        return f"{panel.ylabel.splitlines()[0]}: always {values[0]:g}\n(not plotted)"
    return None


def task_panels(runs: list[dict]) -> list[Panel]:
    """``PANELS`` for runs of one task, items closed in place of success for tasks that count them."""
    return [ITEMS_PANEL if panel.key == "success" and _counts_items(runs) else panel for panel in PANELS]


def _draw_group(ax, algo: str, runs: list[dict], panel: Panel, with_labels: bool) -> None:
    grid, mean, std = mean_and_std(runs, panel.key, panel.axis_key)
    line, = ax.plot(grid, mean, label=f"{algo}, training ({seeds_text(len(runs))})" if with_labels else None,
                    marker="o" if np.isfinite(mean).sum() == 1 else None)
    if len(runs) > 1:
        ax.fill_between(grid, mean - std, mean + std, alpha=0.25, color=line.get_color())
    points = evaluation_points(runs, panel) if panel.evaluation_key else np.empty((0, 2))
    if len(points):
        ax.scatter(points[:, 0], points[:, 1], s=18, marker="D", facecolors="none", edgecolors=line.get_color(),
                   linewidths=1.0, zorder=3, label=evaluation_label(algo, runs) if with_labels else None)


def _leave_out(ax, note: str) -> None:
    ax.set_axis_off()
    ax.text(0.5, 0.5, note, ha="center", va="center", transform=ax.transAxes, color="grey")


def curve_figure(groups: dict[tuple[str, str], list[dict]]):
    """Per task (a column): success rate (or items closed) and return of training episodes against
    episodes (the paper's x-axis), return against wall-clock hours (the equal-budget comparison)
    and the base share of subgoals; rolling means, mean and std over seeds, the periodic
    evaluations as points. A row no task needs (a share constant for every task) is left out, a
    cell of it a task does not need says why; a panel without any data says why."""
    tasks = sorted({task for task, _ in groups})
    runs_of = {task: [run for (t, _), runs in groups.items() if t == task for run in runs] for task in tasks}
    notes = {(task, row): skip_note(runs_of[task], panel) for task in tasks for row, panel in enumerate(PANELS)}
    rows = [row for row in range(len(PANELS)) if any(notes[(task, row)] is None for task in tasks)]
    fig, axes = plt.subplots(len(rows), len(tasks), figsize=(5.5 * len(tasks), 3.4 * len(rows) + 0.6),
                             squeeze=False, layout="constrained")
    for column, task in enumerate(tasks):
        panels = task_panels(runs_of[task])
        for place, row in enumerate(rows):
            ax, panel = axes[place, column], panels[row]
            if notes[(task, row)] is not None:
                _leave_out(ax, notes[(task, row)])
                continue
            for (group_task, algo), runs in sorted(groups.items()):
                if group_task == task:
                    _draw_group(ax, algo, runs, panel, with_labels=place == 0)
            ax.set_xlabel(panel.xlabel)
            ax.set_ylabel(panel.ylabel)
            _note_if_empty(ax, "no episodes logged yet")
        axes[0, column].set_title(task)
        axes[0, column].legend(fontsize=7)
    return fig


def _note_if_empty(ax, note: str) -> None:
    if not any(np.isfinite(line.get_ydata()).any() for line in ax.get_lines()):
        ax.text(0.5, 0.5, note, ha="center", va="center", transform=ax.transAxes, color="grey")


def plot_curves(groups: dict[tuple[str, str], list[dict]], path: Path) -> Path:
    """``curve_figure`` saved as a PNG."""
    fig = curve_figure(groups)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=CURVES_DPI)
    plt.close(fig)
    return path


def write_report(run_dirs: list[Path], out: Path, checkpoint: str = "latest") -> dict[str, str]:
    """Writes ``table.md``, ``table.json`` and ``curves.png`` in ``out``; returns their paths and the
    markdown. The reference table is each run's evaluation of ``checkpoint`` (``final_evaluation``)."""
    groups = collect(run_dirs, checkpoint)
    if not groups:
        raise ValueError("no run directories given")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    references, settings = reference_rows(groups), setting_rows(groups)
    hints = "\n".join(missing_evaluation_hints(groups))
    table = (reference_table(references) + (f"\n\n{hints}" if hints else "")
             + "\n\n## Every evaluation setting\n\n" + settings_table(settings) + "\n")
    (out / "table.md").write_text(table + "\n")
    (out / "table.json").write_text(json.dumps(table_json(references + settings), indent=1) + "\n")
    curves = plot_curves(groups, out / "curves.png")
    return {"table": str(out / "table.md"), "json": str(out / "table.json"), "curves": str(curves), "markdown": table}


def write_curves(run_dirs: list[Path], out: Path) -> Path:
    """Redraws only ``out/curves.png`` from ``run_dirs`` (``relmogen report --curves-only``): a
    report's tables stay as written, e.g. when only the figure's drawing changed."""
    groups = collect(run_dirs)
    if not groups:
        raise ValueError("no run directories given")
    return plot_curves(groups, Path(out) / "curves.png")
