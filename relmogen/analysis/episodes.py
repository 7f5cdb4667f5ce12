"""Where a policy fails, episode by episode, under its own or other settings.

Runs a trained policy (a run, a checkpoint or an exported actor, as ``relmogen eval`` takes it)
greedily in the environment ``relmogen eval`` builds for it (arm collision checking on), with
environment keyword arguments replaced (``base_goal=nearest_reachable``, ``arm_rrt=[100,4]``,
``arm_collision=false``, ...) and ``ArmConfig`` settings applied (``plan_attempts=6``, see
``relmogen.analysis.arm``). Each episode gives one row: success, door state, steps, how it
ended, its CPU seconds and its trace of subgoal outcomes (``b:`` base, ``a:`` arm, numbers as
``#``, ``(R)`` when the action repeated the previous one exactly). The summary counts outcomes
per episode and, for the door tasks, whether failures never opened the door.

    relmogen analyse episodes POLICY [--checkpoint best] [--episodes 10] [--seed 100000]
                              [--set KEY=VALUE ...] [--arm KEY=VALUE ...] [--stochastic] [--out F.jsonl] [--json]
"""

from __future__ import annotations

import collections
import json
import re
import time
from pathlib import Path

import numpy as np

from relmogen.analysis.arm import parse_value, set_arm_settings
from relmogen.experiments.loading import load_trained
from relmogen.experiments.rollout import run_episode


def normalised_reason(reason: str | None) -> str:
    """A subgoal's outcome without numbers: its last clause, digits replaced by ``#``."""
    return re.sub(r"\d[\d.]*", "#", (reason or "ok").split(";")[-1].strip())


def parse_assignments(items: list[str]) -> dict:
    """``["key=value", ...]`` -> ``{key: value}`` (numbers, booleans, None and ``[a,b]`` lists parsed)."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"write KEY=VALUE, got {item!r}")
        value = value.strip()
        out[key.strip()] = ([parse_value(v) for v in value[1:-1].split(",") if v.strip()]
                            if value.startswith("[") and value.endswith("]") else parse_value(value))
    return out


def episode_row(record, seed: int, cpu_s: float) -> dict:
    metrics = record.metrics
    row = {"seed": seed, "success": bool(metrics.get("success")), "steps": record.steps,
           "termination": record.termination, "cpu_s": round(cpu_s, 2)}
    for key in ("door_opened", "door_angle_deg", "goal_distance", "closed_10", "button_pressed"):
        if key in metrics:
            row[key] = round(float(metrics[key]), 3)
    row["trace"] = [f"{s['subgoal_type'][0]}:{normalised_reason(s.get('reason'))}{'(R)' if s.get('repeat') else ''}"
                    for s in record.subgoals]
    return row


def episode_traces(policy: Path, checkpoint: str = "latest", episodes: int = 10, seed: int = 100_000,
                   env_overrides: dict | None = None, arm_settings: dict | None = None,
                   deterministic: bool = True, device: str = "cpu") -> list[dict]:
    """One row per episode (seeds ``seed``, ``seed`` + 1, ...), see the module docstring."""
    trained = load_trained(Path(policy), checkpoint, device=device)
    env = trained.make_env(**(env_overrides or {})).unwrapped
    try:
        if arm_settings:
            set_arm_settings(env, arm_settings)
        act = trained.policy(env, deterministic=deterministic)
        rows = []
        for episode in range(episodes):
            start = time.process_time()
            record = run_episode(env, act, seed + episode)
            rows.append(episode_row(record, seed + episode, time.process_time() - start))
    finally:
        env.close()
    return rows


def failure_kind(row: dict) -> str | None:
    if row["success"]:
        return None
    if "door_opened" in row:
        return "opened, goal not reached" if row["door_opened"] else "door never opened"
    return "not reached"


def summarise_traces(rows: list[dict]) -> dict:
    """Success rate, CPU seconds per episode, each outcome's count per episode, the share of
    repeated subgoals and the failures by kind."""
    n = max(len(rows), 1)
    outcomes = collections.Counter(entry.replace("(R)", "").replace("b:", "base: ", 1).replace("a:", "arm: ", 1)
                                   for row in rows for entry in row["trace"])
    subgoals = [entry for row in rows for entry in row["trace"]]
    return {"episodes": len(rows), "success_rate": round(sum(r["success"] for r in rows) / n, 3),
            "cpu_s_per_episode": round(float(np.mean([r["cpu_s"] for r in rows])) if rows else 0.0, 2),
            "repeated_subgoals": round(sum(e.endswith("(R)") for e in subgoals) / max(len(subgoals), 1), 3),
            "failures": dict(collections.Counter(k for k in map(failure_kind, rows) if k)),
            "outcomes_per_episode": {k: round(v / n, 2) for k, v in sorted(outcomes.items())}}


def write_jsonl(rows: list[dict], path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(json.dumps(row, default=float) + "\n" for row in rows))
    return path
