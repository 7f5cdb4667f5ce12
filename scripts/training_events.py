"""What happened during training, window by window: episodes, wall-clock hours, successes,
button presses (ButtonDoorNav, from the ``reward_terms/button`` TensorBoard scalar) and items
closed within 10 deg / 10 cm (ArrangeKitchenMM, from ``episodes.csv``).

    python scripts/training_events.py runs/sgpd-long/*__relmogen-d__* --window 400
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

from tensorboard.backend.event_processing.event_accumulator import EventAccumulator


def episode_rows(run: Path) -> list[dict]:
    with open(run / "episodes.csv", newline="") as handle:
        return list(csv.DictReader(handle))


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
    rows, pressed = episode_rows(run), pressed_episodes(run)
    summary = []
    for start in range(0, len(rows), window):
        chunk = rows[start:start + window]
        closed = [float(r["closed_10"]) for r in chunk if r.get("closed_10") not in (None, "")]
        summary.append({
            "episodes": f"{chunk[0]['episode']}-{chunk[-1]['episode']}",
            "hours": round(float(chunk[-1]["wall_time_s"]) / 3600, 2),
            "successes": int(sum(float(r["success"]) for r in chunk)),
            "presses": sum(int(r["episode"]) in pressed for r in chunk),
            "closed_10_per_episode": round(sum(closed) / len(closed), 3) if closed else None,
            "mean_return": round(sum(float(r["return"]) for r in chunk) / len(chunk), 2),
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
