"""Does a relmogen-d ButtonDoorNav checkpoint value pushes on the button cap above the rest?

Drives the task's oracle to the states just before its first press of each episode (as
``../sgpd-surface/press_odds.py`` does), computes the checkpoint's Q maps there (arm collision
checking off, as in training) and prints per state: the best Q over the cap's own arm actions
(cells with red cap pixels, all push bins), the best allowed arm and base Q, the percentile of
the best cap action among all allowed actions, and the softmax(Q / T) mass on cap actions for
a few temperatures (the probability that one Boltzmann exploratory action lands on the cap).
Ends with a summary JSON line.

    python results/sgpd-explore/cap_values.py RUN --states 8 --out results/sgpd-explore/cap_values_X.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import torch as th

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import YAW_BINS
from relmogen.experiments.evaluate import load_policy
from relmogen.experiments.oracle import oracle_arm_pushes
from relmogen.experiments.train import env_kwargs
from relmogen.tasks.button_door_nav import button_cap_cells
from relmogen.visualisation.qmap import q_map_state

TEMPERATURES = (1.0, 0.3, 0.1, 0.03)


def cap_row(state, cap: np.ndarray) -> dict:
    base_q = np.where(state.masks[0][None], state.q_maps[:YAW_BINS], -np.inf)
    arm_q = np.where(state.masks[1][None], state.q_maps[YAW_BINS:], -np.inf)
    cap_q = np.where((cap & state.masks[1])[None], state.q_maps[YAW_BINS:], -np.inf)
    allowed = np.concatenate([base_q.ravel(), arm_q.ravel()])
    allowed = allowed[np.isfinite(allowed)]
    best_cap = float(cap_q.max())
    row = {"cap_actions": int(np.isfinite(cap_q).sum()), "allowed_actions": int(allowed.size),
           "best_cap_q": best_cap, "best_arm_q": float(arm_q.max()), "best_base_q": float(base_q.max()),
           "cap_percentile": float(100.0 * np.mean(allowed < best_cap)) if np.isfinite(best_cap) else None}
    for temperature in TEMPERATURES:
        weights = th.softmax(th.as_tensor(allowed / temperature), 0).numpy()
        on_cap = np.isin(allowed, cap_q[np.isfinite(cap_q)])
        row[f"softmax_cap_mass_T{temperature}"] = float(weights[on_cap].sum())
    return row


def checkpoint_arguments(description: str, states: int) -> argparse.Namespace:
    """RUN [--checkpoint] [--states] [--seed] [--out]: the arguments of the oracle-state diagnostics."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("run", type=Path)
    parser.add_argument("--checkpoint", default="latest")
    parser.add_argument("--states", type=int, default=states)
    parser.add_argument("--seed", type=int, default=100_000)
    parser.add_argument("--out", type=Path)
    return parser.parse_args()


def model_and_training_env(args: argparse.Namespace):
    """The checkpoint's model and an environment as in training (arm collision checking off)."""
    model, config, _ = load_policy(args.run, checkpoint=args.checkpoint)
    return model, RelmogenEnv(**env_kwargs(config, arm_collision=False))


def main() -> None:
    args = checkpoint_arguments(__doc__.splitlines()[0], states=8)
    model, env = model_and_training_env(args)
    rows, used = [], set()
    try:
        for episode, step, obs, _ in oracle_arm_pushes(env, 10 * args.states, args.seed):
            if episode in used or env.unwrapped.task.button_pressed():
                continue
            used.add(episode)
            state = q_map_state(model, env, obs, step)
            cap = button_cap_cells(obs["rgb"][None], state.cell_pixels)[0]
            row = {"episode": episode, "step": step, "greedy": state.choice[0], **cap_row(state, cap)}
            rows.append(row)
            print(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()}), flush=True)
            if len(used) >= args.states:
                break
    finally:
        env.close()
    summary = {"run": str(args.run), "checkpoint": args.checkpoint, "states": len(rows)}
    for key in rows[0]:
        if key.startswith(("softmax", "cap_percentile", "best_")):
            summary[f"mean_{key}"] = float(np.mean([r[key] for r in rows if r[key] is not None]))
    print(json.dumps(summary))
    if args.out:
        args.out.write_text(json.dumps({"summary": summary, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
