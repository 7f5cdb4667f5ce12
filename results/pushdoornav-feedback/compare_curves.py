"""Training success against episodes and against CPU hours for five sets of PushDoorNav
ReLMoGen-R runs (3 seeds each): arm collision checking off in training (the paper's), on (first
version of the pushed-body rule), on with `subgoal_feedback` and one update per 2 transitions,
off with `subgoal_feedback`, and the Table I row: off with the feedback for 1,000 episodes
(its `pretraining/` runs), then on, fine-tuned from there (`train --init-from`; those curves start
where their initial weights' budget ends, from `init_from.json`).
CPU hours per episode are the run's wall-clock scaled by its done.json CPU / wall ratio.

    python results/pushdoornav-feedback/compare_curves.py   # writes compare_curves.png here
"""

import csv
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

RESULTS = Path(__file__).resolve().parent.parent
SETS = {
    "collision off in training": RESULTS / "pushdoornav-collision-off",
    "collision on, first rule": RESULTS / "pushdoornav-collision-on",
    "collision on + feedback, 2x updates": RESULTS / "pushdoornav-feedback",
    "collision off + feedback": RESULTS / "pushdoornav-checking-off-feedback",
    "off + feedback 1,000 episodes, then on (Table I)": RESULTS / "table1" / "PushDoorNav__relmogen-r",
}
WINDOW = 100


def run_curve(run: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rows = list(csv.DictReader(open(run / "episodes.csv")))
    done = json.loads((run / "done.json").read_text())
    wall = np.array([float(r["wall_time_s"]) for r in rows])
    success = np.array([float(r["success"]) for r in rows])
    init = json.loads((run / "init_from.json").read_text()) if (run / "init_from.json").is_file() else {}
    rolling = np.convolve(success, np.ones(WINDOW) / WINDOW, mode="valid")
    episodes = np.arange(WINDOW, len(success) + 1) + init.get("initial_episodes", 0)
    cpu_hours = (wall[WINDOW - 1:] * done["cpu_time_s"] / done["wall_time_s"] + init.get("initial_cpu_time_s", 0)) / 3600
    return episodes, cpu_hours, rolling


def main() -> None:
    fig, (by_episode, by_cpu) = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    colours = ("tab:grey", "tab:blue", "tab:red", "tab:green", "tab:purple")
    for (label, folder), colour in zip(SETS.items(), colours):
        runs = sorted(folder.glob("PushDoorNav__relmogen-r__*")) + sorted(folder.glob("pretraining/PushDoorNav__*"))
        for i, run in enumerate(runs):
            episodes, cpu_hours, rolling = run_curve(run)
            by_episode.plot(episodes, rolling, color=colour, alpha=0.8, label=label if i == 0 else None)
            by_cpu.plot(cpu_hours, rolling, color=colour, alpha=0.8)
    by_episode.set(xlabel="training episodes", ylabel=f"training success (last {WINDOW} episodes)")
    by_cpu.set(xlabel="CPU hours (trainer + 2 environment workers)")
    by_episode.legend(loc="upper left", fontsize=8)
    for axis in (by_episode, by_cpu):
        axis.grid(alpha=0.3)
    fig.suptitle("PushDoorNav ReLMoGen-R, reward only, 3 seeds per set (sampled subgoals in training)")
    fig.tight_layout()
    out = Path(__file__).with_name("compare_curves.png")
    fig.savefig(out, dpi=110)
    print(out)


if __name__ == "__main__":
    main()
