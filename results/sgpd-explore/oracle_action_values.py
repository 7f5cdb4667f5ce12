"""Where does a relmogen-d checkpoint rank the oracle's pushes, and how flat are its Q maps?

Drives the task's oracle (seeds 100000+) and, just before each of its arm pushes, computes the
checkpoint's Q maps (arm collision checking off, as in training). Per state it prints the Q of
the oracle's push (its nearest discrete action, ``control.nearest_index``), that action's
percentile among the allowed actions, the best, 90th-percentile and median allowed Q, and the
greedy choice. A flat map (best close to the median, relative to the best) means the greedy
action is picked by small differences: the action gap. Ends with a summary JSON line.

    python results/sgpd-explore/oracle_action_values.py RUN --states 16 --out results/sgpd-explore/oracle_values_X.json
"""

from __future__ import annotations

import json

import numpy as np
from cap_values import checkpoint_arguments, model_and_training_env  # beside this script

from relmogen.experiments.oracle import oracle_arm_pushes
from relmogen.visualisation.qmap import q_map_state


def allowed_q(state) -> np.ndarray:
    """(L + K, Q, Q) Q maps with the masked actions at -inf (base maps first, as the action index)."""
    half = state.q_maps.shape[0] // 2
    base = np.where(state.masks[0][None], state.q_maps[:half], -np.inf)
    arm = np.where(state.masks[1][None], state.q_maps[half:], -np.inf)
    return np.concatenate([base, arm])


def state_row(state, oracle_index: int) -> dict:
    q = allowed_q(state).ravel()
    allowed = q[np.isfinite(q)]
    oracle_q = float(q[oracle_index])
    best, median = float(allowed.max()), float(np.median(allowed))
    return {"allowed_actions": int(allowed.size), "oracle_allowed": bool(np.isfinite(oracle_q)),
            "oracle_q": oracle_q if np.isfinite(oracle_q) else None,
            "oracle_percentile": float(100.0 * np.mean(allowed < oracle_q)) if np.isfinite(oracle_q) else None,
            "best_q": best, "p90_q": float(np.percentile(allowed, 90)), "median_q": median,
            "gap_best_median_rel": (best - median) / abs(best) if best else None,
            "greedy": list(state.choice)}


def main() -> None:
    args = checkpoint_arguments(__doc__.splitlines()[0], states=16)
    model, env = model_and_training_env(args)
    rows = []
    try:
        for episode, step, obs, action in oracle_arm_pushes(env, args.states, args.seed):
            state = q_map_state(model, env, obs, step)
            row = {"episode": episode, "step": step, **state_row(state, env.unwrapped.control.nearest_index(action))}
            rows.append(row)
            print(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in row.items()}), flush=True)
            if len(rows) >= args.states:
                break
    finally:
        env.close()
    summary = {"run": str(args.run), "checkpoint": args.checkpoint, "states": len(rows),
               "oracle_allowed": float(np.mean([r["oracle_allowed"] for r in rows]))}
    for key in ("oracle_percentile", "best_q", "p90_q", "median_q", "gap_best_median_rel", "oracle_q"):
        values = [r[key] for r in rows if r[key] is not None]
        summary[f"mean_{key}"] = float(np.mean(values)) if values else None
    summary["greedy_arm_share"] = float(np.mean([r["greedy"][0] == "arm" for r in rows]))
    print(json.dumps(summary))
    if args.out:
        args.out.write_text(json.dumps({"summary": summary, "states": rows}, indent=1))


if __name__ == "__main__":
    main()
