"""How closely a relmogen-d run's greedy policy follows its stored demonstrations.

For every demonstration row kept in the latest checkpoint's replay (``algo.demo_keep``), the
greedy action under the row's own cell masks is compared with the demonstrated one: the same
action, the same part (base or arm), and, for arm rows, a pixel within one cell. It tells
whether the margin term (``algo.demo_margin_weight``) fitted the demonstrations, apart from
whether the policy then reaches such states by itself.

    python results/sgpd-dqfd/demo_agreement.py runs/sgpd-dqfd/* --json results/sgpd-dqfd/demo_agreement.json
"""

from __future__ import annotations

import argparse
import json
import pickle
from pathlib import Path

import numpy as np
import torch as th
from torch.nn import functional as F

from relmogen.agents.dqn import RelmogenDQN, masked_argmax
from relmogen.envs.subgoal_controls import decode_indices
from relmogen.experiments.train import latest_checkpoint


def greedy_and_shown(model: RelmogenDQN, buffer, rows: np.ndarray, batch: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Greedy and demonstrated actions of every environment's transition in ``rows``; the greedy
    choice is masked with the row's own cell masks (plus the demonstrated action)."""
    pairs = []
    with th.no_grad():
        for env in range(buffer.n_envs):
            for start in range(0, len(rows), batch):
                part = rows[start:start + batch]
                shown = th.as_tensor(buffer.actions[part, env].reshape(-1).astype(np.int64))
                allowed = model.allowed(buffer.masks[part, env], len(part))
                allowed |= F.one_hot(shown, model.action_space.n).bool()
                q_values = model.q_net(buffer._batch(buffer.observations, part, np.full(len(part), env), None))
                pairs.append(np.stack([masked_argmax(q_values, allowed).numpy(), shown.numpy()], axis=1))
    chosen, shown = np.concatenate(pairs).T
    return chosen, shown


def agreement(run: Path) -> dict:
    checkpoint = latest_checkpoint(run)
    if checkpoint is None:
        raise SystemExit(f"{run}: no checkpoint")
    model = RelmogenDQN.load(checkpoint / "model.zip", device="cpu")
    buffer = pickle.loads((checkpoint / "replay_buffer.pkl").read_bytes())
    rows = np.flatnonzero(getattr(buffer, "demo", np.zeros(0, bool)))
    if not len(rows):
        raise SystemExit(f"{run}: no demonstration rows in the replay (was algo.demo_keep set?)")
    buffer.device = th.device("cpu")
    chosen, shown = greedy_and_shown(model, buffer, rows)
    (chosen_arm, _, ci, cj), (arm, _, si, sj) = decode_indices(chosen, model.q), decode_indices(shown, model.q)
    near = (chosen_arm == arm) & (np.abs(ci - si) <= 1) & (np.abs(cj - sj) <= 1)
    return {"run": run.name, "demo_rows": len(chosen), "same_action": float(np.mean(chosen == shown)),
            "same_part": float(np.mean(chosen_arm == arm)), "arm_rows": int(arm.sum()),
            "arm_same_action": float(np.mean((chosen == shown)[arm])) if arm.any() else None,
            "arm_within_one_cell": float(np.mean(near[arm])) if arm.any() else None}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--json", type=Path, help="also write the rows here")
    args = parser.parse_args()
    th.set_num_threads(1)
    results = [agreement(run) for run in args.runs]
    for row in results:
        print(json.dumps(row))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
