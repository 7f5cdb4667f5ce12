"""``relmogen report``: the paper's table (mean / std / max over seeds) and training curves.

Each run directory contributes its final evaluation (the newest ``eval/*.json`` with arm
collision checking on, else the last periodic evaluation) and its ``episodes.csv`` curve.
Curves are averaged over seeds on a common grid of environment episodes (the paper's x-axis).
"""

from __future__ import annotations

import csv
import json
import warnings
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from relmogen.experiments.config import read_config  # noqa: E402

TABLE_METRICS = ("success_rate", "spl", "closed_5", "closed_10")
CURVE_SMOOTHING = 20  # episodes in the moving average of each seed's curve


def policy_of(evaluation: dict) -> str:
    """How actions were chosen; evaluations written before the field existed were deterministic."""
    return evaluation.get("policy", "deterministic")


def final_evaluation(run_dir: Path) -> dict | None:
    """The run's reference evaluation: arm collision checking on, with the planners it was
    trained with, the most episodes, then the newest (planner-swap and scene-transfer
    evaluations sit beside it and are reported separately); else the last periodic one."""
    config = read_config(run_dir / "config.yaml")
    evals = [json.loads(p.read_text()) | {"_mtime": p.stat().st_mtime}
             for p in (run_dir / "eval").glob("*collision-on*.json")]
    evals = [e for e in evals if policy_of(e) == "deterministic"]
    same_planners = [e for e in evals if e.get("base_planner", config.env.base_planner) == config.env.base_planner
                     and e.get("arm_planner", config.env.arm_planner) == config.env.arm_planner
                     and (config.env.scene is None or e.get("scene") == config.env.scene)]
    if same_planners:
        best = max(same_planners, key=lambda e: (e.get("episodes", 0), e["_mtime"]))
        return {k: v for k, v in best.items() if k != "_mtime"}
    periodic = run_dir / "eval_during_training.jsonl"
    if periodic.is_file():
        lines = periodic.read_text().strip().splitlines()
        return json.loads(lines[-1]) if lines else None
    return None


def summarise(values: list[float]) -> dict[str, float]:
    arr = np.asarray(values, dtype=float)
    return {"mean": float(arr.mean()), "std": float(arr.std()), "max": float(arr.max()), "n": len(arr)}


def collect(run_dirs: list[Path]) -> dict[tuple[str, str], list[dict]]:
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for run_dir in map(Path, run_dirs):
        config = read_config(run_dir / "config.yaml")
        groups[(config.task, config.algo)].append({
            "seed": config.seed, "run_dir": run_dir, "eval": final_evaluation(run_dir),
            "all_evals": [json.loads(p.read_text()) for p in sorted((run_dir / "eval").glob("*.json"))],
            "curve": read_curve(run_dir / "episodes.csv"), "state": _state(run_dir),
        })
    return groups


def _state(run_dir: Path) -> dict:
    """Budget spent: ``done.json`` of a finished run, else its latest checkpoint's state."""
    from relmogen.experiments.train import latest_checkpoint

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


def markdown_table(groups: dict[tuple[str, str], list[dict]]) -> str:
    lines = ["| task | algorithm | seeds | " + " | ".join(TABLE_METRICS) + " | episodes | wall-clock h | CPU h |",
             "|---|---|---|" + "---|" * len(TABLE_METRICS) + "---|---|---|"]
    for (task, algo), runs in sorted(groups.items()):
        evaluated = [r for r in runs if r["eval"] is not None]
        cells = []
        for metric in TABLE_METRICS:
            if not evaluated:
                cells.append("-")
                continue
            s = summarise([r["eval"][metric] for r in evaluated])
            cells.append(f"{s['mean']:.2f} / {s['std']:.2f} / {s['max']:.2f}")
        episodes = [r["state"].get("episodes", len(r["curve"]["episode"])) for r in runs]
        hours = [r["state"].get("wall_time_s", 0.0) / 3600 for r in runs]
        cpu = [r["state"]["cpu_time_s"] / 3600 for r in runs if "cpu_time_s" in r["state"]]
        cpu_cell = f"{np.mean(cpu):.2f}" if len(cpu) == len(runs) else "-"
        lines.append(f"| {task} | {algo} | {len(runs)} | " + " | ".join(cells)
                     + f" | {int(np.mean(episodes))} | {np.mean(hours):.2f} | {cpu_cell} |")
    lines.append("")
    lines.append("Cells are mean / std / max over seeds of the final evaluation (deterministic policy). "
                 "episodes, wall-clock h and CPU h (trainer plus environment workers) are means over seeds.")
    return "\n".join(lines)


SETTING_KEYS = ("scene", "base_planner", "arm_planner", "arm_collision", "policy", "episodes")
SETTING_METRICS = ("success_rate", "spl", "closed_10", "subgoal_success_rate", "base_fraction",
                   "repeated_subgoal_rate", "unchanged_view_rate", "oracle_agreement")


def settings_table(groups: dict[tuple[str, str], list[dict]]) -> str:
    """Every evaluation setting found (planner swaps, scene transfer, collision off, episode
    counts): mean / std / max over the seeds evaluated with it."""
    lines = ["| task | algorithm | " + " | ".join(SETTING_KEYS) + " | seeds | " + " | ".join(SETTING_METRICS) + " |",
             "|---|---|" + "---|" * (len(SETTING_KEYS) + 1 + len(SETTING_METRICS))]
    for (task, algo), runs in sorted(groups.items()):
        by_setting: dict[tuple, list[dict]] = defaultdict(list)
        for run in runs:
            for evaluation in run.get("all_evals", []):
                setting = dict(evaluation, policy=policy_of(evaluation))
                by_setting[tuple(str(setting.get(key, "-")) for key in SETTING_KEYS)].append(evaluation)
        for setting, evals in sorted(by_setting.items()):
            cells = []
            for metric in SETTING_METRICS:
                values = [e[metric] for e in evals if metric in e]
                s = summarise(values) if values else None
                cells.append(f"{s['mean']:.2f} / {s['std']:.2f} / {s['max']:.2f}" if s else "-")
            lines.append(f"| {task} | {algo} | " + " | ".join(setting) + f" | {len(evals)} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _smoothed_on_grid(curve: dict, key: str, grid: np.ndarray) -> np.ndarray:
    episodes, values = curve["episode"], curve[key]
    if len(values) == 0:
        return np.full(len(grid), np.nan)
    kernel = min(CURVE_SMOOTHING, len(values))
    smooth = np.convolve(values, np.ones(kernel) / kernel, mode="valid")
    return np.interp(grid, episodes[kernel - 1:], smooth, left=np.nan, right=np.nan)


PANELS = (("success", "episode", "success rate", "environment episodes"),
          ("return", "episode", "episode return", "environment episodes"),
          ("return", "hours", "episode return", "wall-clock hours"),
          ("base_fraction", "episode", "base share of subgoals", "environment episodes"))


def _mean_and_std(runs: list[dict], key: str, axis_key: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seed mean and std of the smoothed ``key`` on a common grid of episodes or hours."""
    curves = [dict(r["curve"], hours=r["curve"]["wall_time_s"] / 3600) for r in runs]
    last = max(c[axis_key].max(initial=0) for c in curves)
    start = 1.0 if axis_key == "episode" else 0.0
    grid = np.linspace(start, max(last, start + 1e-6), 200)
    values = np.array([_smoothed_on_grid(dict(c, episode=c[axis_key]), key, grid) for c in curves])
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # grid points no seed reached yet
        return grid, np.nanmean(values, axis=0), np.nanstd(values, axis=0)


def _counts_items(runs: list[dict]) -> bool:
    """Runs of a task scored by items closed (logged per episode since that column exists)."""
    return any(np.isfinite(r["curve"]["closed_10"]).any() for r in runs)


def plot_curves(groups: dict[tuple[str, str], list[dict]], path: Path) -> Path:
    """Per task: success rate and return against episodes (the paper's x-axis) and return
    against wall-clock hours (the equal-budget comparison); mean and std over seeds."""
    tasks = sorted({task for task, _ in groups})
    fig, axes = plt.subplots(len(PANELS), len(tasks), figsize=(5.5 * len(tasks), 13), squeeze=False)
    for column, task in enumerate(tasks):
        for (group_task, algo), runs in sorted(groups.items()):
            if group_task != task:
                continue
            counts_items = _counts_items(runs)
            for row, (key, axis_key, ylabel, xlabel) in enumerate(PANELS):
                if key == "success" and counts_items:
                    key, ylabel = "closed_10", "items closed (10 deg / 10 cm)"
                grid, mean, std = _mean_and_std(runs, key, axis_key)
                ax = axes[row, column]
                ax.plot(grid, mean, label=f"{algo} ({len(runs)} seeds)")
                ax.fill_between(grid, mean - std, mean + std, alpha=0.25)
                ax.set_xlabel(xlabel)
                ax.set_ylabel(ylabel)
        axes[0, column].set_title(task)
        axes[0, column].legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_report(run_dirs: list[Path], out: Path) -> dict[str, str]:
    groups = collect(run_dirs)
    if not groups:
        raise ValueError("no run directories given")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    table = markdown_table(groups)
    table += "\n\n## Every evaluation setting\n\n" + settings_table(groups) + "\n"
    (out / "table.md").write_text(table + "\n")
    curves = plot_curves(groups, out / "curves.png")
    return {"table": str(out / "table.md"), "curves": str(curves), "markdown": table}
