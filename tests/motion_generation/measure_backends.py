"""Success rate and planning time of every backend on seeded doorway / cluttered base problems.

Run from the repo root: ``PYTHONPATH=. python tests/motion_generation/measure_backends.py [n]``
(not a test; ``n`` problems of each kind).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from mg_maps import cluttered_map, doorway_map, random_free_goal  # noqa: E402

from relmogen.motion_generation.base_planner import (  # noqa: E402
    FETCH_FOOTPRINT_RADIUS,
    FootprintChecker,
    make_base_planner,
    plan_base,
)
from relmogen.motion_generation.planners import BACKENDS  # noqa: E402


def doorway_problem(rng: np.random.Generator):
    wall_x = rng.uniform(0.8, 1.4)
    local_map = doorway_map(wall_x=wall_x, gap_centre_y=rng.uniform(-1.5, 1.5), gap=1.0)
    checker = FootprintChecker(local_map, FETCH_FOOTPRINT_RADIUS)
    while True:
        goal = np.array([rng.uniform(wall_x + 0.4, 2.2), rng.uniform(-2.2, 2.2), rng.uniform(-np.pi, np.pi)])
        if not checker.footprint_hits_obstacle(goal):
            return local_map, goal


def cluttered_problem(rng: np.random.Generator):
    local_map = cluttered_map(rng, n_obstacles=int(rng.integers(10, 20)))
    return local_map, random_free_goal(local_map, rng)


def main(n_problems: int = 30) -> None:
    rng = np.random.default_rng(2024)
    makers = (("doorway", doorway_problem), ("cluttered", cluttered_problem))
    problems = [(kind, *maker(rng)) for kind, maker in makers for _ in range(n_problems)]
    for backend in sorted(BACKENDS):
        planner = make_base_planner(backend)
        plan_base(*problems[0][1:], planner, rng=0)  # warm-up (imports)
        for kind in ("doorway", "cluttered"):
            results = [plan_base(m, g, planner, rng=i) for i, (k, m, g) in enumerate(problems) if k == kind]
            times = np.array([r.planning_time_s for r in results])
            ok = np.array([r.success for r in results])
            direct = sum(r.reason == "direct connection" for r in results)
            lengths = [r.path_length_m for r in results if r.success]
            print(f"{backend:16s} {kind:9s} success {ok.mean():5.0%}  median {np.median(times) * 1e3:7.1f} ms"
                  f"  p90 {np.percentile(times, 90) * 1e3:7.1f} ms  direct {direct:2d}"
                  f"  median length {np.median(lengths) if lengths else float('nan'):.2f} m")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 30)
