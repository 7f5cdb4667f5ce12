"""``relmogen bench planner``: every planner backend on the same fixed, seeded scene problems.

The problems (``planner_problems``) are generated once per run from ``--seed``; each backend
plans every one of them with the production settings (``make_base_planner`` for the base, the
``ArmMotion`` planner for the arm, arm collision checking on) and the same per-problem seed.

Base problems count as *feasible* when a backend solved them, when they are rotations (by
construction), or when an oracle with a generous budget (OMPL RRT-Connect 3 s, RRT-Connect with
500 iterations x 10 restarts) solves them; base success rates and times are over feasible
problems. Arm figures are over the problems whose IK had a collision-free solution.

Per backend and kind: ``success_rate``, ``median_ms`` and ``p95_ms`` of the planning time,
``mean_path_length`` (metres driven for the base; joint-space length of torso + 7 arm joints for
the arm) over solved problems, and the success rate per category. Undefined figures are null.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from relmogen.bench.planner_problems import (
    ARM_CATEGORIES,
    BASE_CATEGORIES,
    BaseProblem,
    arm_problem,
    base_problems,
    make_envs,
)
from relmogen.motion_generation.base_planner import make_base_planner, plan_base
from relmogen.motion_generation.planners import BACKENDS

BACKEND_NAMES = tuple(BACKENDS)
ORACLES = (("ompl_rrtconnect", {"time_limit_s": 3.0}),
           ("rrt_connect", {"iterations": 500, "restarts": 10, "max_time_s": 3.0}))
COMPARED = ("rrt_connect", "ompl_rrtconnect")
Progress = Callable[[], None]


@dataclass(frozen=True)
class Attempt:
    backend: str
    kind: str  # "base" or "arm"
    category: str
    problem: int  # index within its kind
    success: bool
    time_ms: float
    path_length: float


def planning_runs(per_category: int) -> int:
    """How many (problem, backend) plans a run makes (the progress bar's total)."""
    return (len(BASE_CATEGORIES) + len(ARM_CATEGORIES)) * per_category * len(BACKEND_NAMES)


# ----------------------------------------------------------------------------- base


def _base_attempt(problem: BaseProblem, index: int, backend: str, planner) -> Attempt:
    result = plan_base(problem.local_map, problem.goal_robot, planner, rng=problem.seed)
    return Attempt(backend, "base", problem.category, index, result.success,
                   result.planning_time_s * 1e3, result.path_length_m)


def _warm_up(problem: BaseProblem, planners: dict) -> None:
    """One untimed plan per backend: module imports and first-call costs stay out of the figures."""
    for planner in planners.values():
        plan_base(problem.local_map, problem.goal_robot, planner, rng=0)


def run_base(problems: list[BaseProblem], advance: Progress) -> list[Attempt]:
    planners = {name: make_base_planner(name) for name in BACKEND_NAMES}
    _warm_up(problems[0], planners)
    attempts = []
    for index, problem in enumerate(problems):
        for name, planner in planners.items():
            attempts.append(_base_attempt(problem, index, name, planner))
            advance()
    return attempts


def oracle_solves(problem: BaseProblem) -> bool:
    return any(plan_base(problem.local_map, problem.goal_robot, make_base_planner(name, **params),
                         rng=problem.seed).success for name, params in ORACLES)


def feasible_problems(problems: list[BaseProblem], attempts: list[Attempt]) -> set[int]:
    solved = {a.problem for a in attempts if a.success}
    return {i for i, problem in enumerate(problems)
            if i in solved or problem.category == "rotation" or oracle_solves(problem)}


# ----------------------------------------------------------------------------- arm


def _joint_path_length(path: list[np.ndarray]) -> float:
    return float(np.sum(np.linalg.norm(np.diff(np.asarray(path), axis=0), axis=1)))


def _arm_attempts(env, problem, index: int, advance: Progress) -> list[Attempt]:
    arm, attempts = env.control.mg.arm, []
    for name in BACKEND_NAMES:
        arm.set_planner(name)
        result = arm.plan(problem.goal_config, np.random.default_rng(problem.seed))
        length = _joint_path_length(result.path) if result.success else 0.0
        attempts.append(Attempt(name, "arm", problem.category, index, result.success,
                                result.planning_time_s * 1e3, length))
        advance()
    arm.set_planner(env.control.mg.config.arm_planner)
    return attempts


def run_arm(envs: dict, per_category: int, seed: int, advance: Progress) -> tuple[list[Attempt], dict]:
    """All arm attempts, plus per-category counts of problems and IK failures."""
    attempts, counts = [], {c: {"problems": 0, "ik_failures": 0, "ik_targets_tried": 0} for c in ARM_CATEGORIES}
    for c, category in enumerate(ARM_CATEGORIES):
        for i in range(per_category):
            with arm_problem(envs, category, seed * 10_000 + 5_000 + c * 1_000 + i) as (env, problem):
                counts[category]["problems"] += 1
                if problem is None:
                    counts[category]["ik_failures"] += 1
                    for _ in BACKEND_NAMES:
                        advance()
                    continue
                counts[category]["ik_targets_tried"] += problem.ik_attempts
                attempts += _arm_attempts(env, problem, len({a.problem for a in attempts}), advance)
    return attempts, counts


# ----------------------------------------------------------------------------- statistics


def _round(value: float | None, digits: int = 3) -> float | None:
    return None if value is None or not np.isfinite(value) else round(float(value), digits)


def _rate(attempts: list[Attempt]) -> float | None:
    return _round(np.mean([a.success for a in attempts])) if attempts else None


def backend_stats(attempts: list[Attempt], categories: tuple[str, ...]) -> dict:
    """One backend's figures over ``attempts`` (one kind)."""
    times = np.array([a.time_ms for a in attempts])
    lengths = [a.path_length for a in attempts if a.success]
    return {
        "attempts": len(attempts),
        "success_rate": _rate(attempts),
        "median_ms": _round(np.median(times)) if len(times) else None,
        "p95_ms": _round(np.percentile(times, 95)) if len(times) else None,
        "mean_path_length": _round(np.mean(lengths)) if lengths else None,
        "success_by_category": {c: _rate([a for a in attempts if a.category == c]) for c in categories},
    }


def comparison(attempts: list[Attempt], first: str, second: str) -> dict:
    """Success-rate difference and median planning-time ratio of two backends, same problems."""
    a = [x for x in attempts if x.backend == first]
    b = [x for x in attempts if x.backend == second]
    if not a or not b:
        return {"success_delta": None, "median_ratio": None}
    median_a, median_b = np.median([x.time_ms for x in a]), np.median([x.time_ms for x in b])
    return {"success_delta": _round(np.mean([x.success for x in a]) - np.mean([x.success for x in b])),
            "median_ratio": _round(median_a / median_b) if median_b > 0 else None}


def _per_backend(attempts: list[Attempt], categories: tuple[str, ...]) -> dict:
    return {name: backend_stats([a for a in attempts if a.backend == name], categories) for name in BACKEND_NAMES}


# ----------------------------------------------------------------------------- entry point


def _base_summary(problems: list[BaseProblem], feasible: set[int]) -> dict:
    return {
        "problems": len(problems),
        "feasible": len(feasible),
        "feasible_by_category": {c: sum(problems[i].category == c for i in feasible) for c in BASE_CATEGORIES},
        "scenes": sorted({problem.scene for problem in problems}),
    }


def bench_planner(problems: int = 3, seed: int = 0, advance: Progress | None = None, robot: str = "fetch") -> dict:
    """Run the suite (``problems`` per category) with ``robot`` and return one JSON-ready dict."""
    advance = advance or (lambda: None)
    start = time.perf_counter()
    envs = make_envs(robot)
    try:
        suite = base_problems(envs, problems, seed)
        base_attempts = run_base(suite, advance)
        feasible = feasible_problems(suite, base_attempts)
        base_attempts = [a for a in base_attempts if a.problem in feasible]
        arm_attempts, arm_counts = run_arm(envs, problems, seed, advance)
    finally:
        for env in envs.values():
            env.close()
    base_stats, arm_stats = _per_backend(base_attempts, BASE_CATEGORIES), _per_backend(arm_attempts, ARM_CATEGORIES)
    return {
        "seed": seed,
        "robot": robot,
        "problems_per_category": problems,
        "backends": list(BACKEND_NAMES),
        "base": _base_summary(suite, feasible),
        "arm": {"solved_by_any": len({a.problem for a in arm_attempts if a.success}), "by_category": arm_counts},
        "results": {name: {"base": base_stats[name], "arm": arm_stats[name]} for name in BACKEND_NAMES},
        f"{COMPARED[0]}_vs_{COMPARED[1]}": comparison(base_attempts, *COMPARED),
        f"{COMPARED[0]}_vs_{COMPARED[1]}_arm": comparison(arm_attempts, *COMPARED),
        "wall_time_s": round(time.perf_counter() - start, 1),
    }


def print_planner_table(result: dict) -> None:
    """The per-backend figures as a rich table (the non-JSON output)."""
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"bench planner, {result.get('robot', 'fetch')} ({result['problems_per_category']} problems per category, "
                        f"seed {result['seed']}, {result['base']['feasible']} feasible base problems)")
    for column in ("backend", "kind", "success", "median ms", "p95 ms", "mean path", "success by category"):
        table.add_column(column, justify="left" if column in ("backend", "kind", "success by category") else "right")
    for name, kinds in result["results"].items():
        for kind, stats in kinds.items():
            by_category = "  ".join(f"{c} {_fmt(v)}" for c, v in stats["success_by_category"].items())
            table.add_row(name, kind, _fmt(stats["success_rate"]), _fmt(stats["median_ms"], 1),
                          _fmt(stats["p95_ms"], 1), _fmt(stats["mean_path_length"]), by_category)
    console = Console()
    console.print(table)
    for key in (k for k in result if "_vs_" in k):
        console.print(f"{key}: {result[key]}")
    console.print(f"wall time {result['wall_time_s']} s")


def _fmt(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"
