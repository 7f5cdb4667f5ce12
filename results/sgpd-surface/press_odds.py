"""How likely is a uniformly random allowed SGP-D arm action to press the ButtonDoorNav button?

Drives the task's oracle to the states where it is about to press (standing 0.55-0.75 m from
the wall, facing the button). In each such state and for each push frame (``env.push_frame``),
every allowed arm action on the cells within one cell of the button cap (red pixels) is
executed from the same saved physics state, and presses (cap deeper than 3 cm) are counted.
Pushes further from the cap are taken not to press, so the odds are a lower bound. Each row
also gives the cap cells (red pixels) and the share of their pushes that pressed: how precise
a push must be. Prints a Markdown row per state and frame, then one JSON summary.

    python results/sgpd-surface/press_odds.py --states 8 --out results/sgpd-surface/press_odds.json
    python results/sgpd-surface/press_odds.py --states 8 --qmap-size 32 --frames surface \
        --out results/sgpd-explore/press_odds_q32.json       # the cpu preset's 32 x 32 maps
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from scipy.ndimage import binary_dilation

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import PUSH_BINS, PUSH_FRAMES, SubgoalDControl
from relmogen.experiments.oracle import oracle_arm_pushes
from relmogen.tasks.button_door_nav import button_cap_cells

TASK = "ButtonDoorNav"


def presses_near_cap(env: RelmogenEnv, control: SubgoalDControl) -> dict:
    """Every allowed arm action within one cell of the cap, each from the same saved state."""
    unwrapped = env.unwrapped
    unwrapped.control = control
    obs = unwrapped._observe()
    mask = control.extra_info()["arm_mask"]
    cap = button_cap_cells(obs["rgb"][None], obs["rgb"].shape[0] // control.q)[0]
    near = binary_dilation(cap, np.ones((3, 3), bool)) & mask
    mechanism, saved = unwrapped.task.mechanism, unwrapped.world.save_state()
    presses = cap_presses = 0
    try:
        for i, j in zip(*np.nonzero(near)):
            for bin_ in range(PUSH_BINS):
                control.step(control.encode("arm", bin_, int(i), int(j)))
                presses += bool(mechanism.pressed)
                cap_presses += bool(mechanism.pressed) and bool(cap[i, j])
                unwrapped.world.restore_state(saved)
                mechanism.pressed, mechanism._last_angle = False, 0.0
                mechanism.door.lock()
                unwrapped._observe()  # the frame, masks and headings of the saved state again
    finally:
        unwrapped.world.remove_state(saved)
    return {"allowed_arm_actions": int(mask.sum()) * PUSH_BINS, "tried_near_cap": int(near.sum()) * PUSH_BINS,
            "presses": presses, "tried_on_cap": int((cap & mask).sum()) * PUSH_BINS, "presses_on_cap": cap_presses}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=8)
    parser.add_argument("--seed", type=int, default=100_000)
    parser.add_argument("--image-size", type=int, default=64)
    parser.add_argument("--qmap-size", type=int, default=None, help="Q-map side (default image size / 4)")
    parser.add_argument("--frames", nargs="+", default=list(PUSH_FRAMES), choices=PUSH_FRAMES)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    env = RelmogenEnv(task=TASK, control="subgoal-d", image_size=args.image_size, qmap_size=args.qmap_size)
    controls = {frame: SubgoalDControl(env.unwrapped, push_frame=frame, arm_collision=False, qmap_size=args.qmap_size)
                for frame in args.frames}
    rows = []
    print("| episode | step | frame | allowed arm actions | tried near the cap | presses | odds | on the cap: pressed / tried |")
    print("|---|---|---|---|---|---|---|---|")
    try:
        used = set()
        for episode, step, _, _ in oracle_arm_pushes(env, 10 * args.states, args.seed):
            if episode in used or env.unwrapped.task.button_pressed():
                continue  # one state per episode, before its first press
            used.add(episode)
            own = env.unwrapped.control
            for frame, control in controls.items():
                row = {"episode": episode, "step": step, "frame": frame, **presses_near_cap(env, control)}
                rows.append(row)
                odds = row["presses"] / max(row["allowed_arm_actions"], 1)
                print(f"| {episode} | {step} | {frame} | {row['allowed_arm_actions']} | {row['tried_near_cap']} "
                      f"| {row['presses']} | {odds:.4f} | {row['presses_on_cap']} / {row['tried_on_cap']} |", flush=True)
            env.unwrapped.control = own
            if len(used) >= args.states:
                break
    finally:
        env.close()
    keys = ("allowed_arm_actions", "tried_near_cap", "presses", "tried_on_cap", "presses_on_cap")
    summary = {frame: {key: sum(r[key] for r in rows if r["frame"] == frame) for key in keys} for frame in args.frames}
    for totals in summary.values():
        totals["odds_per_random_arm_action"] = totals["presses"] / max(totals["allowed_arm_actions"], 1)
    result = {"task": TASK, "states": len(rows) // len(args.frames), "image_size": args.image_size,
              "qmap_size": env.unwrapped.control.q,
              "arm_collision": False, "per_frame": summary, "rows": rows}
    print(json.dumps(result["per_frame"]))
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
