"""Where did an SGP-D ButtonDoorNav run push, according to its own replay buffer?

For every stored arm push, looks at the RGB observation it was chosen on: was the button cap
(red: R > 100, G < 60, B < 60, the only red in ButtonDoorNav) in view, and did the pushed
Q-map cell (its 4 x 4 pixel block) contain cap pixels? Prints one Markdown row per run:
pushes with the cap in view, pushes on the cap, and which of them were rewarded by a press
(reward >= 5: the +5 button reward, or +10 success).

    python results/sgpd-cql/replay_button_pushes.py runs/sgpd-button/ButtonDoorNav__*
"""

from __future__ import annotations

import argparse
import pickle
from pathlib import Path

import numpy as np

from relmogen.agents.replay import stored_rows
from relmogen.envs.subgoal_controls import Q_DOWNSAMPLE, decode_indices
from relmogen.experiments.train import latest_replay
from relmogen.tasks.button_door_nav import button_cap_cells

PRESS_REWARD = 5.0


def push_counts(replay) -> dict[str, int]:
    rows = stored_rows(replay)
    rgb = replay.observations["rgb"][rows]  # (rows, envs, ...)
    rgb = rgb.reshape(-1, *rgb.shape[2:])
    actions = replay.actions[rows].reshape(-1).astype(int)
    rewards = replay.rewards[rows].reshape(-1)
    cells = button_cap_cells(rgb, Q_DOWNSAMPLE)
    q = cells.shape[1]
    arm, _, i, j = decode_indices(actions, q)
    in_view = cells.any(axis=(1, 2))
    on_cap = arm & cells[np.arange(len(actions)), i, j]
    pressed = rewards >= PRESS_REWARD
    return {"transitions": len(actions), "arm pushes": int(arm.sum()), "cap in view": int((arm & in_view).sum()),
            "on the cap": int(on_cap.sum()), "on the cap, rewarded": int((on_cap & pressed).sum()),
            "elsewhere, rewarded": int((arm & ~on_cap & pressed).sum())}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    args = parser.parse_args()
    header = None
    for run in args.runs:
        replay = latest_replay(run)
        if replay is None:
            raise SystemExit(f"{run} has no saved replay buffer")
        with open(replay, "rb") as file:
            counts = push_counts(pickle.load(file))
        if header is None:
            header = list(counts)
            print("| run | " + " | ".join(header) + " |")
            print("|---" * (len(header) + 1) + "|")
        print(f"| {run.name} | " + " | ".join(f"{counts[key]:,}" for key in header) + " |")


if __name__ == "__main__":
    main()
