"""What happened during training runs, window by window, and their curves.

Reads a run's ``episodes.csv`` and its TensorBoard scalars (TensorBoard steps are training
episodes; a resumed run writes another event file, whose values win for the same step):
training success, returns, episode length, arm share, items closed, button presses (the
``reward_terms/button`` term), the SAC critic's value estimate (minus the actor loss), the
entropy temperature, relmogen-d's TD loss and Q level (``losses/q_taken``).

    relmogen analyse training RUN... [--window 100 | --phases] [--json]
    relmogen analyse curves RUN... [--group LABEL RUN...] [--window 100] [--cpu-hours] [--tags TAG...] --out PNG
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

# column of ``windows`` -> (TensorBoard tag, sign, reduction)
SCALAR_COLUMNS = {
    "value_estimate": ("losses/actor_loss", -1.0, "mean"),
    "temperature": ("losses/ent_coef", 1.0, "mean"),
    "td_loss": ("losses/loss", 1.0, "median"),
    "q_taken": ("losses/q_taken", 1.0, "mean"),
}
BUTTON_TAG = "reward_terms/button"
SMOOTH = 25  # logged values per point of a scalar's median line


def episode_rows(run: Path) -> list[dict[str, float]]:
    """``episodes.csv`` as numbers (NaN for an empty cell)."""
    with open(Path(run) / "episodes.csv", newline="") as handle:
        return [{key: float(value) if value not in ("", None) else math.nan for key, value in row.items()}
                for row in csv.DictReader(handle)]


def scalar_series(run: Path, tag: str) -> tuple[np.ndarray, np.ndarray]:
    """(steps, values) of a TensorBoard scalar over every event file under ``run/tb``, sorted by
    step; later files win for the same step."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    points: dict[int, float] = {}
    for events in sorted((Path(run) / "tb").rglob("events.out.tfevents.*")):
        accumulator = EventAccumulator(str(events), size_guidance={"scalars": 0})
        accumulator.Reload()
        if tag in accumulator.Tags()["scalars"]:
            points.update({event.step: event.value for event in accumulator.Scalars(tag)})
    steps = np.array(sorted(points), dtype=np.int64)
    return steps, np.array([points[int(step)] for step in steps], dtype=np.float64)


def phase_starts(run: Path) -> list[int]:
    """Row offsets where a resume with ``--set`` changed the run's settings (``resumes.jsonl``)."""
    log = Path(run) / "resumes.jsonl"
    entries = [json.loads(line) for line in log.read_text().splitlines() if line.strip()] if log.is_file() else []
    return [0] + [int(entry["from_episode"]) for entry in entries if entry.get("set")]


def _mean(values) -> float | None:
    values = np.asarray([v for v in values if np.isfinite(v)], dtype=float)
    return round(float(values.mean()), 4) if values.size else None


def windows(run: Path, window: int | None = 100) -> list[dict]:
    """One row per ``window`` episodes (``None``: per settings phase, see ``phase_starts``), with
    every column the run has: ``episodes`` (first-last), ``hours`` (wall clock at its end),
    ``train_success``, ``successes``, ``mean_return``, ``length``, ``arm_share``,
    ``closed_10_per_episode``, ``presses`` and the ``SCALAR_COLUMNS``."""
    run = Path(run)
    rows = episode_rows(run)
    if not rows:
        return []
    starts = phase_starts(run) if window is None else list(range(0, len(rows), int(window)))
    scalars = {name: (scalar_series(run, tag), sign, how) for name, (tag, sign, how) in SCALAR_COLUMNS.items()}
    press_steps, press_values = scalar_series(run, BUTTON_TAG)
    pressed = set(press_steps[press_values > 0].tolist())
    out = []
    for start, end in zip(starts, starts[1:] + [len(rows)]):
        part = rows[start:end]
        if not part:
            continue
        first, last = int(part[0]["episode"]), int(part[-1]["episode"])
        row = {"episodes": f"{first}-{last}", "hours": round(part[-1]["wall_time_s"] / 3600, 2),
               "train_success": _mean(r["success"] for r in part), "successes": int(sum(r["success"] for r in part)),
               "mean_return": _mean(r["return"] for r in part), "length": _mean(r.get("length", math.nan) for r in part)}
        arm_share = _mean(1.0 - r.get("base_fraction", math.nan) for r in part)
        closed = _mean(r.get("closed_10", math.nan) for r in part)
        row.update({key: value for key, value in (("arm_share", arm_share), ("closed_10_per_episode", closed))
                    if value is not None})
        if press_steps.size:
            row["presses"] = sum(first <= step <= last for step in pressed)
        for name, ((steps, values), sign, how) in scalars.items():
            inside = values[(steps >= first) & (steps <= last)]
            if inside.size:
                row[name] = round(float(sign * (np.median(inside) if how == "median" else inside.mean())), 4)
        out.append(row)
    return out


def rolling_success(run: Path, window: int = 100) -> dict[str, np.ndarray]:
    """Training success over the last ``window`` episodes against the episode and the CPU hours
    (wall clock scaled by ``done.json``'s CPU / wall ratio; a fine-tuned run starts where its
    initial weights' budget ended, from ``init_from.json``)."""
    run = Path(run)
    rows = episode_rows(run)
    success = np.array([r["success"] for r in rows])
    wall = np.array([r["wall_time_s"] for r in rows])
    init = json.loads((run / "init_from.json").read_text()) if (run / "init_from.json").is_file() else {}
    done = json.loads((run / "done.json").read_text()) if (run / "done.json").is_file() else {}
    ratio = done["cpu_time_s"] / done["wall_time_s"] if done.get("wall_time_s") else 1.0
    window = min(int(window), len(success)) or 1
    rolling = np.convolve(success, np.ones(window) / window, mode="valid")
    episodes = np.arange(window, len(success) + 1) + float(init.get("initial_episodes", 0))
    cpu_hours = (wall[window - 1:] * ratio + float(init.get("initial_cpu_time_s", 0.0))) / 3600
    return {"episode": episodes, "cpu_hours": cpu_hours, "success": rolling}


def rolling_median(values: np.ndarray, width: int = SMOOTH) -> np.ndarray:
    if len(values) < width:
        return values
    medians = np.median(np.lib.stride_tricks.sliding_window_view(values, width), axis=1)
    return np.concatenate([np.full(width - 1, np.nan), medians])


def plot_curves(groups: dict[str, list[Path]], out: Path, window: int = 100, cpu_hours: bool = False,
                tags: tuple[str, ...] = ()) -> Path:
    """One colour per group of runs: rolling training success against episodes (and against CPU
    hours), and each TensorBoard ``tags`` scalar (median of ``SMOOTH``; log scale for losses)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = 1 + int(cpu_hours) + len(tags)
    figure, axes = plt.subplots(1, panels, figsize=(5.5 * panels, 4), squeeze=False)
    axes = axes[0]
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (label, runs) in enumerate(groups.items()):
        colour = colours[k % len(colours)]
        for i, run in enumerate(runs):
            curve = rolling_success(run, window)
            axes[0].plot(curve["episode"], curve["success"], color=colour, alpha=0.8, label=label if i == 0 else None)
            if cpu_hours:
                axes[1].plot(curve["cpu_hours"], curve["success"], color=colour, alpha=0.8)
            for axis, tag in zip(axes[1 + int(cpu_hours):], tags):
                steps, values = scalar_series(run, tag)
                plot = axis.semilogy if "loss" in tag and (values > 0).all() else axis.plot
                plot(steps, rolling_median(values), color=colour, alpha=0.8)
    axes[0].set(xlabel="training episodes", ylabel=f"training success (last {window} episodes)")
    if cpu_hours:
        axes[1].set(xlabel="CPU hours (wall clock x done.json's CPU / wall)")
    for axis, tag in zip(axes[1 + int(cpu_hours):], tags):
        axis.set(xlabel="training episode", title=f"{tag} (median of {SMOOTH})")
    for axis in axes:
        axis.grid(alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=8)
    figure.tight_layout()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(out, dpi=110)
    plt.close(figure)
    return out
