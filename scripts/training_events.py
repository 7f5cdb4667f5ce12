"""What happened during training, window by window: episodes, wall-clock hours, successes,
button presses (ButtonDoorNav, from the ``reward_terms/button`` TensorBoard scalar) and items
closed within 10 deg / 10 cm (ArrangeKitchenMM, from ``episodes.csv``).

    python scripts/training_events.py runs/sgpd-long/*__relmogen-d__* --window 400
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from relmogen.experiments.report import read_curve


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


def windows(run: Path, window: int) -> list[dict]:
    curve, pressed = read_curve(run / "episodes.csv"), pressed_episodes(run)
    summary = []
    for start in range(0, len(curve["episode"]), window):
        part = {key: values[start:start + window] for key, values in curve.items()}
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
    args = parser.parse_args()
    if args.window < 1:
        parser.error("--window must be positive")
    print("| run | episodes | hours (end) | successes | button presses | closed_10 per episode | mean return |")
    print("|---|---|---|---|---|---|---|")
    for run in args.runs:
        for row in windows(run, args.window):
            closed = "-" if row["closed_10_per_episode"] is None else row["closed_10_per_episode"]
            print(f"| {run.name} | {row['episodes']} | {row['hours']} | {row['successes']} | {row['presses']} "
                  f"| {closed} | {row['mean_return']} |")


if __name__ == "__main__":
    main()
