"""TD loss, Q level and training return against episodes for relmogen-d runs, from their
TensorBoard logs and episodes.csv: does the Q function diverge once epsilon reaches its floor?
(The Q level, ``losses/q_taken``, is logged by runs started or resumed from 2026-12-04 on.)

    python results/sgpd-explore/loss_curves.py RUN [RUN ...] --out results/sgpd-explore/loss_curves.png
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator  # noqa: E402

WINDOW = 200  # episodes per point of the return curve
SMOOTH = 25  # logged losses per point of the median line


def rolling_median(values: np.ndarray) -> np.ndarray:
    if len(values) < SMOOTH:
        return values
    medians = np.median(np.lib.stride_tricks.sliding_window_view(values, SMOOTH), axis=1)
    return np.concatenate([np.full(SMOOTH - 1, np.nan), medians])


def scalar_by_episode(run: Path, tag: str) -> tuple[np.ndarray, np.ndarray]:
    """(episodes, values) of a scalar over every TensorBoard file of the run; later files win."""
    points: dict[int, float] = {}
    for events in sorted((run / "tb").glob("events.out.tfevents.*")):
        accumulator = EventAccumulator(str(events))
        accumulator.Reload()
        if tag in accumulator.Tags()["scalars"]:
            points.update({e.step: e.value for e in accumulator.Scalars(tag)})
    steps = np.array(sorted(points))
    return steps, np.array([points[s] for s in steps])


def windowed_return(run: Path) -> tuple[np.ndarray, np.ndarray]:
    with open(run / "episodes.csv") as f:
        returns = np.array([float(row["return"]) for row in csv.DictReader(f)])
    n = len(returns) // WINDOW
    means = returns[: n * WINDOW].reshape(n, WINDOW).mean(axis=1)
    return (np.arange(n) + 1) * WINDOW, means


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=Path, nargs="+")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    figure, (loss_axis, q_axis, return_axis) = plt.subplots(1, 3, figsize=(16, 4))
    for run in args.runs:
        label = f"{run.parent.name}/{run.name.split('__')[2]}"
        episodes, loss = scalar_by_episode(run, "losses/loss")
        line, = loss_axis.semilogy(episodes, loss, alpha=0.25)
        loss_axis.semilogy(episodes, rolling_median(loss), color=line.get_color(), label=f"{label} (median of {SMOOTH})")
        q_episodes, q_taken = scalar_by_episode(run, "losses/q_taken")
        q_axis.plot(q_episodes, rolling_median(q_taken), color=line.get_color(), label=label)
        return_axis.plot(*windowed_return(run), marker="o", color=line.get_color(), label=label)
    loss_axis.set(xlabel="training episode", ylabel="logged loss (Huber TD, plus any add-on term)", title="loss")
    q_axis.set(xlabel="training episode", ylabel=f"mean Q of the taken actions (median of {SMOOTH})", title="Q level")
    return_axis.set(xlabel="training episode", ylabel=f"mean return per {WINDOW} episodes", title="training return")
    for axis in (loss_axis, q_axis, return_axis):
        axis.grid(alpha=0.3)
        axis.legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(args.out, dpi=110)
    print(args.out)


if __name__ == "__main__":
    main()
