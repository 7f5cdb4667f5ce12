"""The generic planner interface on a joint-space problem (the arm uses the same interface)."""

from __future__ import annotations

import numpy as np
import pytest

from relmogen.motion_generation.planners import (
    BACKENDS,
    LazyPRMParams,
    PlanningProblem,
    RRTConnectParams,
    make_planner,
)

RESOLUTION = 0.05
OBSTACLE_CENTRE, OBSTACLE_RADIUS = np.zeros(8), 0.6


def sphere_problem() -> PlanningProblem:
    """8-D box with a ball-shaped forbidden region between start and goal."""
    return PlanningProblem(
        start=np.full(8, -0.5),
        goal=np.full(8, 0.5),
        lower=np.full(8, -1.0),
        upper=np.full(8, 1.0),
        collision_fn=lambda q: bool(np.linalg.norm(q - OBSTACLE_CENTRE) < OBSTACLE_RADIUS),
        resolutions=np.full(8, RESOLUTION),
    )


@pytest.mark.parametrize("backend", sorted(BACKENDS))
def test_joint_space_around_sphere(backend):
    problem = sphere_problem()
    result = make_planner(backend).plan(problem, rng=3)
    assert result.success, result.reason
    assert result.backend == backend
    path = np.array(result.path)
    np.testing.assert_allclose(path[0], problem.start)
    np.testing.assert_allclose(path[-1], problem.goal)
    assert np.all(np.abs(np.diff(path, axis=0)) <= RESOLUTION + 1e-9)
    assert not any(problem.collision_fn(q) for q in path)
    assert np.all(path >= problem.lower - 1e-9) and np.all(path <= problem.upper + 1e-9)


@pytest.mark.parametrize("backend", sorted(BACKENDS))
def test_free_space_uses_direct_connection(backend):
    problem = sphere_problem()
    problem.collision_fn = lambda q: False
    result = make_planner(backend).plan(problem, rng=0)
    assert result.reason == "direct connection"


@pytest.mark.parametrize("backend", sorted(BACKENDS))
def test_colliding_endpoints_fail_with_reason(backend):
    problem = sphere_problem()
    problem.goal = np.zeros(8)
    assert make_planner(backend).plan(problem, rng=0).reason == "goal in collision"
    problem = sphere_problem()
    problem.start = np.zeros(8)
    assert make_planner(backend).plan(problem, rng=0).reason == "start in collision"


def test_unknown_backend_lists_valid_names():
    with pytest.raises(ValueError, match="rrt_connect") as info:
        make_planner("rrt_star")
    for name in BACKENDS:
        assert name in str(info.value)


def test_params_defaults_and_overrides():
    assert make_planner("rrt_connect").params == RRTConnectParams(20, 2, 20)
    assert make_planner("lazy_prm").params.roadmap_sizes == (500, 2000, 5000)
    assert make_planner("ompl_prm", time_limit_s=0.2).params.time_limit_s == 0.2
    with pytest.raises(TypeError):
        make_planner("lazy_prm", RRTConnectParams())
    assert make_planner("lazy_prm", LazyPRMParams(roadmap_sizes=(50,))).params.roadmap_sizes == (50,)


@pytest.mark.parametrize("backend", ["rrt_connect", "lazy_prm", "ompl_rrtconnect"])
def test_determinism(backend):
    planner = make_planner(backend)
    first, second = planner.plan(sphere_problem(), rng=11), planner.plan(sphere_problem(), rng=11)
    np.testing.assert_array_equal(np.array(first.path), np.array(second.path))


def test_global_rngs_untouched():
    import random

    random.seed(5)
    np.random.seed(5)
    expected = (random.random(), np.random.random())
    random.seed(5)
    np.random.seed(5)
    make_planner("rrt_connect").plan(sphere_problem(), rng=0)
    assert (random.random(), np.random.random()) == expected


def test_lazy_prm_gives_up_at_its_time_limit():
    """Without a limit, a lazy search retries after every colliding edge and then tries every
    larger roadmap (one failing PointNav base plan took 206 s)."""
    import time

    problem = sphere_problem()
    problem.goal = np.full(8, 0.05)  # sealed inside a shell: no path exists

    def slow_collision_fn(q):
        time.sleep(0.002)
        return bool(0.3 < np.linalg.norm(q) < 0.6)

    problem.collision_fn = slow_collision_fn
    result = make_planner("lazy_prm", roadmap_sizes=(200, 200), max_time_s=0.05).plan(problem, rng=0)
    assert result.reason == "time limit reached"
    assert make_planner("lazy_prm").params.max_time_s == 10.0


def test_lazy_prm_distance_is_the_weighted_euclidean_norm():
    from relmogen.motion_generation.planners import _weighted_distance_fn

    rng = np.random.default_rng(0)
    weights = rng.uniform(1, 30, 8)
    distance = _weighted_distance_fn(weights)
    for _ in range(20):
        a, b = rng.normal(size=8), rng.normal(size=8)
        assert distance(a, b) == pytest.approx(np.linalg.norm(weights * b - weights * a))
    with pytest.raises(ValueError, match="Euclidean"):
        _weighted_distance_fn(weights, p_norm=1)
