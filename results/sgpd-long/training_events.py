"""What happened during training, window by window: episodes, wall-clock hours, successes,
button presses (ButtonDoorNav, from the ``reward_terms/button`` TensorBoard scalar) and items
closed within 10 deg / 10 cm (ArrangeKitchenMM, from ``episodes.csv``).

    python results/sgpd-long/training_events.py runs/sgpd-long/*__relmogen-d__* --window 400
    python results/sgpd-long/training_events.py runs/sgpd-button/* --phases   # one row per resume that changed settings
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from relmogen.experiments.report import read_curve
from relmogen.experiments.train import read_resume_log


def pressed_episodes(run: Path) -> set[int]:
    """Episodes whose summed ``button`` reward term is positive (every TensorBoard file of the
    run: a resumed run writes a new one)."""
    pressed = set()
    for events in sorted((run / "tb").glob("events.out.tfevents.*")):
        accumulator = EventAccumulator(str(events), size_guidance={"scalars": 0})
        accumulator.Reload()
        if "reward_terms/button" in accumulator.Tags()["scalars"]:
            pressed |= {e.step for e in accumulator.Scalars("reward_terms/button") if e.value > 0}
    return pressed


def phase_starts(run: Path) -> list[int]:
    """Row offsets where a resume with ``--set`` changed the run's settings (``resumes.jsonl``)."""
    return [0] + [entry["from_episode"] for entry in read_resume_log(run) if entry.get("set")]


def windows(run: Path, window: int | None) -> list[dict]:
    """Rows of ``window`` episodes, or (``None``) one row per settings phase."""
    curve, pressed = read_curve(run / "episodes.csv"), pressed_episodes(run)
    total = len(curve["episode"])
    starts = phase_starts(run) if window is None else list(range(0, total, window))
    summary = []
    for start, end in zip(starts, starts[1:] + [total]):
        part = {key: values[start:end] for key, values in curve.items()}
        episodes, closed = part["episode"].astype(int), part["closed_10"][np.isfinite(part["closed_10"])]
        summary.append({
            "episodes": f"{episodes[0]}-{episodes[-1]}",
            "hours": round(float(part["wall_time_s"][-1]) / 3600, 2),
            "successes": int(part["success"].sum()),
            "presses": sum(int(e) in pressed for e in episodes),
            "closed_10_per_episode": round(float(closed.mean()), 3) if closed.size else None,
            "mean_return": round(float(part["return"].mean()), 2),
        })
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--window", type=int, default=400, help="episodes per row (default 400)")
    parser.add_argument("--phases", action="store_true",
                        help="one row per settings phase instead: split where a resume changed settings")
    args = parser.parse_args()
    if args.window < 1:
        parser.error("--window must be positive")
    print("| run | episodes | hours (end) | successes | button presses | closed_10 per episode | mean return |")
    print("|---|---|---|---|---|---|---|")
    for run in args.runs:
        for row in windows(run, None if args.phases else args.window):
            closed = "-" if row["closed_10_per_episode"] is None else row["closed_10_per_episode"]
            print(f"| {run.name} | {row['episodes']} | {row['hours']} | {row['successes']} | {row['presses']} "
                  f"| {closed} | {row['mean_return']} |")


if __name__ == "__main__":
    main()
