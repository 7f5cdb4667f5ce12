"""What a relmogen-d checkpoint's Q maps value, at the oracle's states or along its greedy episodes.

``oracle_states``: the task oracle drives (seeds ``seed``+, arm collision checking off as in
training); just before each of its arm pushes, the checkpoint's Q maps there: the oracle's push
(its nearest discrete action) and its percentile among the allowed actions, the best, 90th
percentile and median allowed Q, the greedy choice; on ButtonDoorNav also the best Q on the
button cap's own cells and the softmax(Q / T) mass on them (the chance that one Boltzmann
exploratory action lands on the cap). ``button_only`` keeps the state before each episode's first
press only.

``greedy_values``: the checkpoint's greedy episodes (checking on): per step the part chosen, the
best allowed base and arm Q, the reward and whether the action repeated the previous one.

``oracle_cell_table``: the ``oracle_cells.json`` that ``relmogen viz qmap RUN --drive oracle``
writes, per stage folder and task: the oracle cell's mean percentile (mean / std / max over seeds).

    relmogen analyse qvalues oracle RUN [--checkpoint latest] [--states 16] [--button-only] [--json]
    relmogen analyse qvalues greedy RUN [--checkpoint latest] [--episodes 10] [--json]
    relmogen analyse oracle-cells STAGE_DIR... [--json]
"""

from __future__ import annotations

import json
from collections import defaultdict
from pathlib import Path

import numpy as np
import torch as th

from relmogen.envs.subgoal_controls import YAW_BINS
from relmogen.experiments.loading import load_trained
from relmogen.experiments.oracle import oracle_arm_pushes
from relmogen.experiments.report import summarise
from relmogen.tasks.button_door_nav import button_cap_cells
from relmogen.visualisation.qmap import q_map_state

TEMPERATURES = (1.0, 0.3, 0.1, 0.03)


def allowed_q(state) -> np.ndarray:
    """(L + K, Q, Q) Q maps, masked actions at -inf (base maps first, as the action index)."""
    base = np.where(state.masks[0][None], state.q_maps[:YAW_BINS], -np.inf)
    arm = np.where(state.masks[1][None], state.q_maps[YAW_BINS:], -np.inf)
    return np.concatenate([base, arm])


def state_row(state, oracle_index: int) -> dict:
    """The oracle's action's Q and percentile among the allowed actions, and how flat the map is."""
    q = allowed_q(state).ravel()
    allowed = q[np.isfinite(q)]
    oracle_q = float(q[oracle_index])
    best, median = float(allowed.max()), float(np.median(allowed))
    found = np.isfinite(oracle_q)
    return {"allowed_actions": int(allowed.size), "oracle_allowed": bool(found),
            "oracle_q": oracle_q if found else None,
            "oracle_percentile": float(100.0 * np.mean(allowed < oracle_q)) if found else None,
            "best_q": best, "p90_q": float(np.percentile(allowed, 90)), "median_q": median,
            "gap_best_median_rel": (best - median) / abs(best) if best else None, "greedy": list(state.choice)}


def cap_row(state, cap: np.ndarray) -> dict:
    """The best Q on the button cap's cells (any push bin), its percentile among the allowed
    actions, and the softmax(Q / T) mass on cap actions per temperature."""
    q = allowed_q(state)
    cap_q = np.where((cap & state.masks[1])[None], state.q_maps[YAW_BINS:], -np.inf)
    allowed = q[np.isfinite(q)]
    best_cap = float(cap_q.max())
    row = {"cap_actions": int(np.isfinite(cap_q).sum()), "best_cap_q": best_cap if np.isfinite(best_cap) else None,
           "best_arm_q": float(q[YAW_BINS:].max()), "best_base_q": float(q[:YAW_BINS].max()),
           "cap_percentile": float(100.0 * np.mean(allowed < best_cap)) if np.isfinite(best_cap) else None}
    on_cap = np.concatenate([np.zeros_like(q[:YAW_BINS], bool), np.isfinite(cap_q)])[np.isfinite(q)]
    for temperature in TEMPERATURES:
        weights = th.softmax(th.as_tensor(allowed / temperature), 0).numpy()
        row[f"softmax_cap_mass_T{temperature}"] = float(weights[on_cap].sum())
    return row


def oracle_states(run: Path, checkpoint: str = "latest", states: int = 16, seed: int = 100_000,
                  button_only: bool = False, max_episodes: int | None = None, **env_overrides) -> list[dict]:
    """One row per oracle arm push (see the module docstring), at most ``states``."""
    trained = load_trained(Path(run), checkpoint, device="cpu")
    model = trained.model
    env = trained.make_env(**{"arm_collision": False, **env_overrides}).unwrapped
    rows, used = [], set()
    try:
        for episode, step, obs, action in oracle_arm_pushes(env, max_episodes or 10 * states, seed):
            if button_only and (episode in used or env.task.button_pressed()):
                continue
            used.add(episode)
            state = q_map_state(model, env, obs, step)
            row = {"episode": seed + episode, "step": step, **state_row(state, env.control.nearest_index(action))}
            if trained.config.task == "ButtonDoorNav":
                row.update(cap_row(state, button_cap_cells(obs["rgb"][None], state.cell_pixels)[0]))
            rows.append(row)
            if len(rows) >= states:
                break
    finally:
        env.close()
    return rows


def oracle_states_summary(rows: list[dict]) -> dict:
    """Means over states of every numeric column; the greedy arm share; how many states share the
    most frequent greedy arm action."""
    summary: dict = {"states": len(rows)}
    for key in rows[0] if rows else ():
        values = [r[key] for r in rows if isinstance(r.get(key), (int, float)) and not isinstance(r.get(key), bool)]
        if values and key not in ("episode", "step"):
            summary[f"mean_{key}"] = round(float(np.mean(values)), 4)
    if rows:
        summary["oracle_allowed"] = round(float(np.mean([r["oracle_allowed"] for r in rows])), 3)
        summary["greedy_arm_share"] = round(float(np.mean([r["greedy"][0] == "arm" for r in rows])), 3)
        greedy = [tuple(r["greedy"]) for r in rows]
        summary["most_frequent_greedy"] = max(greedy, key=greedy.count)
        summary["states_with_most_frequent_greedy"] = greedy.count(summary["most_frequent_greedy"])
    return summary


def best_allowed(q_maps: np.ndarray, mask: np.ndarray) -> float | None:
    values = q_maps.max(axis=0)
    return float(values[mask].max()) if mask.any() else None


def greedy_values(run: Path, checkpoint: str = "latest", episodes: int = 10, seed: int = 100_000,
                  **env_overrides) -> list[dict]:
    """One row per greedy episode (checking on): steps, arm steps, return, the mean best allowed
    base and arm Q, the arm steps' reward, repeats; with its ``steps`` for ``greedy_summary``."""
    trained = load_trained(Path(run), checkpoint, device="cpu")
    model = trained.model
    env = trained.make_env(**env_overrides).unwrapped
    rows = []
    try:
        for episode in range(episodes):
            obs, _ = env.reset(seed=seed + episode)
            steps, previous, done = [], None, False
            while not done:
                state = q_map_state(model, env, obs, len(steps))
                obs, reward, terminated, truncated, _ = env.step(env.control.encode(*state.choice))
                steps.append({"part": state.choice[0], "reward": float(reward), "repeat": state.choice == previous,
                              "base_q": best_allowed(state.q_maps[:YAW_BINS], state.masks[0]),
                              "arm_q": best_allowed(state.q_maps[YAW_BINS:], state.masks[1])})
                previous, done = state.choice, terminated or truncated
            arm = [s for s in steps if s["part"] == "arm"]
            rows.append({"seed": seed + episode, "steps": len(steps), "arm": len(arm),
                         "return": round(sum(s["reward"] for s in steps), 3),
                         "mean_base_q": _mean(s["base_q"] for s in steps), "mean_arm_q": _mean(s["arm_q"] for s in steps),
                         "arm_reward": round(sum(s["reward"] for s in arm), 3),
                         "repeats": sum(s["repeat"] for s in steps), "per_step": steps})
    finally:
        env.close()
    return rows


def _mean(values) -> float | None:
    values = [v for v in values if v is not None]
    return round(float(np.mean(values)), 3) if values else None


def greedy_summary(rows: list[dict]) -> dict:
    """Over every step: the arm share, the arm steps' mean reward, the mean best base and arm Q,
    how often the best base Q is below zero, and the share of repeats."""
    steps = [s for row in rows for s in row["per_step"]]
    arm = [s for s in steps if s["part"] == "arm"]
    return {"steps": len(steps), "arm_share": round(len(arm) / max(len(steps), 1), 3),
            "arm_steps_reward_mean": _mean(s["reward"] for s in arm),
            "base_q_mean": _mean(s["base_q"] for s in steps), "arm_q_mean": _mean(s["arm_q"] for s in steps),
            "base_q_below_zero": _mean(float(s["base_q"] < 0) for s in steps if s["base_q"] is not None),
            "repeat_share": _mean(float(s["repeat"]) for s in steps)}


def oracle_cell_table(stages: list[Path]) -> list[dict]:
    """One row per stage folder and task, from ``<stage>/<task>__relmogen-d__<seed>__.../oracle_cells.json``."""
    rows = []
    for stage in map(Path, stages):
        by_task: dict[str, list[dict]] = defaultdict(list)
        for path in sorted(stage.glob("*/oracle_cells.json")):
            by_task[path.parent.name.split("__")[0]].append(json.loads(path.read_text()))
        if not by_task:
            raise ValueError(f"no */oracle_cells.json under {stage}")
        for task, seeds in sorted(by_task.items()):
            percentile = summarise([s["mean_percentile"] for s in seeds])
            areas = [s.get("mean_area_percentile") for s in seeds]
            area = summarise(areas) if None not in areas else None
            states = sum(s["pushes"] for s in seeds)
            rows.append({"stage": stage.name, "task": task, "seeds": len(seeds), "states_per_seed": states // len(seeds),
                         "percentile": [round(percentile[k], 1) for k in ("mean", "std", "max")],
                         "area_percentile": [round(area[k], 1) for k in ("mean", "std", "max")] if area else None,
                         "greedy_arm": sum(s["greedy_arm"] for s in seeds),
                         "greedy_is_oracle_cell": sum(s["greedy_is_oracle_cell"] for s in seeds), "states": states})
    return rows
