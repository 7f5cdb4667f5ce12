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


# ----------------------------------------------------------------------------- speed-ups, same answers


def boxes_problem(seed: int) -> PlanningProblem:
    """4-D, unequal resolutions, six random box obstacles."""
    centres = np.random.default_rng(seed).uniform(-1, 1, (6, 4))
    return PlanningProblem(
        start=np.full(4, -0.9), goal=np.full(4, 0.9), lower=np.full(4, -1.0), upper=np.full(4, 1.0),
        collision_fn=lambda q: bool(np.any(np.all(np.abs(q - centres) < 0.35, axis=1))),
        resolutions=np.array([0.05, 0.05, 0.1, 0.02]))


def base_problem(seed: int) -> PlanningProblem:
    """The base's problem: its own extension (turn, drive, turn) and distance."""
    from mg_maps import cluttered_map, random_free_goal

    from relmogen.motion_generation.base_planner import FETCH_FOOTPRINT_RADIUS, FootprintChecker, base_planning_problem

    rng = np.random.default_rng(seed)
    local_map = cluttered_map(rng, 20)
    return base_planning_problem(local_map, random_free_goal(local_map, rng),
                                 FootprintChecker(local_map, FETCH_FOOTPRINT_RADIUS))


def birrt_reference(params: RRTConnectParams):
    """The rrt_connect backend as it was: pybullet-planning's own ``birrt`` (its nearest-neighbour
    scan, its smoothing and waypoint extraction)."""
    from relmogen.motion_generation.planners import PybulletRRTConnectPlanner, _pp_collision_fn, _seeded_global_rngs

    class Birrt(PybulletRRTConnectPlanner):
        def _solve(self, problem, rng):
            from pybullet_planning.motion_planners import birrt

            with _seeded_global_rngs(rng):
                path = birrt(problem.start, problem.goal, problem.distance, problem.sample_fn(rng), problem.extend,
                             _pp_collision_fn(problem), max_iterations=params.iterations, restarts=params.restarts,
                             smooth=params.smoothing_iterations, max_time=params.max_time_s)
            return (path, "planned") if path is not None else (None, "no path found")

    return Birrt(params)


@pytest.mark.parametrize("make_problem", [lambda seed: sphere_problem(), boxes_problem, base_problem])
def test_rrt_connect_returns_pybullet_plannings_birrt_path_for_the_same_seed(make_problem):
    outcomes = set()
    for seed in range(6):
        for params in (RRTConnectParams(), RRTConnectParams(iterations=4, restarts=1)):
            ours = make_planner("rrt_connect", params).plan(make_problem(seed), rng=seed)
            theirs = birrt_reference(params).plan(make_problem(seed), rng=seed)
            assert ours.reason == theirs.reason
            assert (ours.path is None) == (theirs.path is None)
            if ours.path is not None:
                np.testing.assert_array_equal(np.array(ours.path), np.array(theirs.path))
            outcomes.add(ours.reason)
    assert "planned" in outcomes


def test_a_plan_checks_each_state_once():
    problem = sphere_problem()
    checked: list[bytes] = []
    inner = problem.collision_fn
    problem.collision_fn = lambda q: checked.append(q.tobytes()) or inner(q)
    assert make_planner("rrt_connect").plan(problem, rng=3).success
    assert len(checked) == len(set(checked))


def test_waypoints_and_redundancy_removal_equal_pybullet_plannings():
    from pybullet_planning.motion_planners.utils import remove_redundant, waypoints_from_path

    from relmogen.motion_generation.planners import _remove_redundant, _waypoints_from_path

    rng = np.random.default_rng(0)
    for _ in range(300):
        dimension = int(rng.integers(2, 9))
        corners = rng.uniform(-1, 1, (int(rng.integers(1, 6)), dimension))
        path = []
        for a, b in zip(corners[:-1], corners[1:]):
            path += list(a + (b - a) * (np.arange(int(rng.integers(1, 30))) / 30)[:, None])
            if rng.random() < 0.3:
                path.append(path[-1].copy())  # RRT paths repeat the node an extension starts from
        path.append(corners[-1])
        if rng.random() < 0.3:
            path = [q + rng.normal(0.0, 3e-4, dimension) for q in path]  # near the 1e-3 tolerance
        for ours, theirs in ((_waypoints_from_path, waypoints_from_path), (_remove_redundant, remove_redundant)):
            expected = theirs(path)
            assert len(ours(path)) == len(expected)
            assert all(np.array_equal(a, b) for a, b in zip(ours(path), expected))
