"""Sampling-based motion planners behind one interface.

Four backends, selected by name with :func:`make_planner` and interchangeable at any time
(the paper swaps RRT-Connect for Lazy PRM at test time):

* ``rrt_connect``      RRT-Connect with restarts + pybullet-planning's shortcutting: its ``birrt``
                       step for step (the same path for the same seed), nearest neighbours in numpy
* ``lazy_prm``         pybullet-planning's ``lazy_prm`` over growing roadmap sizes
* ``ompl_rrtconnect``  OMPL's ``RRTConnect`` (official Python bindings)
* ``ompl_prm``         OMPL's ``PRM``

A :class:`PlanningProblem` holds a box-bounded configuration space, a collision function and
per-dimension resolutions (maximum step). Every backend first tries the direct connection,
then plans, and the result is always re-interpolated with the problem's extension function and
re-checked state by state, so a returned path is collision-free at the problem's resolution.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import random
import sys
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, Callable, Iterator, Sequence

import numpy as np

Config = np.ndarray
CollisionFn = Callable[[Config], bool]
ExtendFn = Callable[[Config, Config], list[Config]]
DistanceFn = Callable[[Config, Config], float]
RngLike = np.random.Generator | int | None


# ----------------------------------------------------------------------------- problem


def linear_extend_fn(resolutions: np.ndarray) -> ExtendFn:
    """Straight line in configuration space; both ends included.

    The number of steps follows pybullet-planning's ``get_extend_fn``: the L2 norm of the
    resolution-scaled difference, so no coordinate moves more than its resolution per step.
    """
    resolutions = np.asarray(resolutions, dtype=np.float64)

    def extend(q1: Config, q2: Config) -> list[Config]:
        steps = int(np.ceil(np.linalg.norm((q2 - q1) / resolutions)))
        # one array op for all states (the same values as q1 + (q2 - q1) * (k / steps) per k)
        states = q1 + (q2 - q1) * (np.arange(steps) / steps)[:, None]
        return [*states, np.array(q2, dtype=np.float64)]

    return extend


def scaled_distance_fn(resolutions: np.ndarray) -> DistanceFn:
    """Euclidean distance in units of resolution steps (the metric OMPL and Lazy PRM see), in
    plain Python: RRT-Connect's nearest-neighbour scan calls it for every tree node."""
    inverse = np.atleast_1d(1.0 / np.asarray(resolutions, dtype=np.float64)).tolist()

    def distance(q1: Config, q2: Config) -> float:
        a, b = np.asarray(q1).tolist(), np.asarray(q2).tolist()
        weights = inverse if len(inverse) == len(a) else inverse * len(a)
        return math.sqrt(sum(((y - x) * w) ** 2 for x, y, w in zip(a, b, weights)))

    return distance


@dataclass
class PlanningProblem:
    """Plan from ``start`` to ``goal`` inside the box ``[lower, upper]``.

    ``collision_fn(q)`` returns True when ``q`` is in collision. ``resolutions`` is the maximum
    per-dimension step between consecutive output waypoints. ``extend_fn(q1, q2)`` (both ends
    included) and ``distance_fn`` default to the straight line and the resolution-scaled
    Euclidean distance; give both when the system cannot follow straight lines.
    """

    start: Config
    goal: Config
    lower: Config
    upper: Config
    collision_fn: CollisionFn
    resolutions: Config
    extend_fn: ExtendFn | None = None
    distance_fn: DistanceFn | None = None

    def __post_init__(self) -> None:
        for name in ("start", "goal", "lower", "upper"):
            setattr(self, name, np.asarray(getattr(self, name), dtype=np.float64).copy())
        self.resolutions = np.broadcast_to(
            np.asarray(self.resolutions, dtype=np.float64), self.start.shape
        ).copy()
        shapes = {a.shape for a in (self.start, self.goal, self.lower, self.upper)}
        if len(shapes) != 1 or self.start.ndim != 1:
            raise ValueError(f"start, goal, lower, upper must be 1-D of equal length, got {shapes}")
        if np.any(self.upper <= self.lower) or np.any(self.resolutions <= 0):
            raise ValueError("need lower < upper and positive resolutions")
        # built once: the planners call extend and distance for every tree node
        self._extend = self.extend_fn or linear_extend_fn(self.resolutions)
        self._distance = self.distance_fn or scaled_distance_fn(self.resolutions)
        self._inverse_resolutions = 1.0 / self.resolutions

    @property
    def dimension(self) -> int:
        return self.start.shape[0]

    @property
    def has_custom_extend(self) -> bool:
        return self.extend_fn is not None

    def extend(self, q1: Config, q2: Config) -> list[Config]:
        states = self._extend(np.asarray(q1), np.asarray(q2))
        if self.extend_fn is None:
            return states  # already float64 arrays
        return [np.asarray(q, dtype=np.float64) for q in states]

    def distance(self, q1: Config, q2: Config) -> float:
        return float(self._distance(np.asarray(q1), np.asarray(q2)))

    def extend_length(self, q1: Config, q2: Config) -> int:
        """``len(self.extend(q1, q2))``, without building the states for the straight line."""
        if self.extend_fn is not None:
            return len(self.extend(q1, q2))
        return int(np.ceil(np.linalg.norm((np.asarray(q2) - np.asarray(q1)) / self.resolutions))) + 1

    def nearest(self, configs: np.ndarray, target: Config) -> int:
        """Index of the row of ``configs`` nearest to ``target`` by ``distance`` (the first of
        equals). The default metric is one numpy expression with the same float operations, in the
        same order, as ``scaled_distance_fn``, so the same node wins."""
        if self.distance_fn is not None:
            scores = [self.distance(q, target) for q in configs]
            return scores.index(min(scores))
        squares = ((np.asarray(target) - configs) * self._inverse_resolutions) ** 2
        total = squares[:, 0].copy()
        for column in squares.T[1:]:
            total += column
        return int(np.argmin(np.sqrt(total)))

    def in_bounds(self, q: Config) -> bool:
        return bool(np.all(q >= self.lower) and np.all(q <= self.upper))

    def in_collision(self, q: Config) -> bool:
        return bool(self.collision_fn(np.asarray(q, dtype=np.float64)))

    def with_remembered_collisions(self) -> PlanningProblem:
        """A copy whose collision function checks each state once: a plan meets the same states
        again (both ends on every RRT restart, the direct path twice, the final verification the
        shortcut segments: a fifth of an arm plan's checks), and a check is the arm's largest cost.
        Assumes the collision function does not change during the copy's life."""
        collision_fn, checked = self.collision_fn, {}

        def remembered(q: Config) -> bool:
            key = q.tobytes()
            if key not in checked:
                checked[key] = bool(collision_fn(q))
            return checked[key]

        return dataclasses.replace(self, collision_fn=remembered)

    def sample_fn(self, rng: np.random.Generator) -> Callable[[], Config]:
        return lambda: rng.uniform(self.lower, self.upper)


@dataclass(frozen=True)
class PlanResult:
    path: list[np.ndarray] | None  # start .. goal, spaced at most `resolutions` apart
    reason: str
    planning_time_s: float
    backend: str

    @property
    def success(self) -> bool:
        return self.path is not None


# ----------------------------------------------------------------------------- parameters


@dataclass(frozen=True)
class RRTConnectParams:
    """pybullet-planning ``birrt``; defaults are the paper's."""

    iterations: int = 20
    restarts: int = 2
    smoothing_iterations: int = 20
    max_time_s: float = math.inf
    try_direct: bool = True  # birrt always tries it; kept for a uniform interface


@dataclass(frozen=True)
class LazyPRMParams:
    """pybullet-planning ``lazy_prm``, retried with each roadmap size until a path is found."""

    roadmap_sizes: tuple[int, ...] = (500, 2000, 5000)
    max_degree: int = 10
    smoothing_iterations: int = 20
    # A plan with no path searches the lazily-pruned roadmap again after every colliding edge:
    # one failing PointNav base plan took 206 s. Solved arm plans take 0.5 s median, 7 s p95
    # (`relmogen bench planner`); the base overrides this with 2 s (base_planner.py).
    max_time_s: float = 10.0
    try_direct: bool = True


@dataclass(frozen=True)
class OMPLRRTConnectParams:
    time_limit_s: float = 1.0
    range: float = 0.0  # in resolution steps; 0 lets OMPL choose
    # Simplification rounds (OMPL reduceVertices, partialShortcutPath, collapseCloseVertices),
    # like the paper's 20 smoothing iterations; 0 = none. Counted in steps, not seconds, so the
    # same seed gives the same path on a loaded machine (a 0.1 s time budget did not). Against
    # that budget (`relmogen bench planner`): arm paths 8.4 vs 7.0, base 1.50 vs 1.40, arm
    # planning 0.30 s vs 1.02 s median.
    simplify_steps: int = 20
    try_direct: bool = True


@dataclass(frozen=True)
class OMPLPRMParams:
    time_limit_s: float = 1.0
    max_nearest_neighbors: int = 10
    simplify_steps: int = 20  # shortcut rounds, as for OMPL RRT-Connect
    try_direct: bool = True


# ----------------------------------------------------------------------------- base class


def as_generator(rng: RngLike) -> np.random.Generator:
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


class Planner(ABC):
    """Stateless between calls: ``plan`` may be called with any problem, any number of times."""

    backend: str = ""

    def __init__(self, params: Any) -> None:
        self.params = params

    def plan(self, problem: PlanningProblem, rng: RngLike = None) -> PlanResult:
        start_time = time.perf_counter()
        rng = as_generator(rng)
        problem = problem.with_remembered_collisions()
        path, reason = self._plan(problem, rng)
        if path is not None:
            path, reason = _interpolate_and_verify(problem, path, reason)
        return PlanResult(path, reason, time.perf_counter() - start_time, self.backend)

    def _plan(self, problem: PlanningProblem, rng: np.random.Generator) -> tuple[list | None, str]:
        reason = _endpoint_failure(problem)
        if reason:
            return None, reason
        if np.allclose(problem.start, problem.goal, rtol=0.0, atol=1e-12):
            return [problem.start, problem.goal], "start equals goal"
        if self.params.try_direct:
            direct = _direct_path(problem)
            if direct is not None:
                return direct, "direct connection"
        return self._solve(problem, rng)

    @abstractmethod
    def _solve(self, problem: PlanningProblem, rng: np.random.Generator) -> tuple[list | None, str]:
        """Waypoints (any spacing) from start to goal, or None, plus a reason string."""


def _endpoint_failure(problem: PlanningProblem) -> str:
    if not problem.in_bounds(problem.start):
        return "start out of bounds"
    if not problem.in_bounds(problem.goal):
        return "goal out of bounds"
    if problem.in_collision(problem.start):
        return "start in collision"
    if problem.in_collision(problem.goal):
        return "goal in collision"
    return ""


def _direct_path(problem: PlanningProblem) -> list[Config] | None:
    path = problem.extend(problem.start, problem.goal)
    return None if any(problem.in_collision(q) for q in path) else path


def _interpolate_and_verify(problem: PlanningProblem, waypoints: Sequence[Config], reason: str):
    """Re-interpolate with the problem's extension and check every state (the planners'
    shortcutting returns sparse waypoints and is not guaranteed to have checked them all)."""
    dense = [np.asarray(waypoints[0], dtype=np.float64)]
    for q1, q2 in zip(waypoints[:-1], waypoints[1:]):
        dense.extend(problem.extend(q1, q2)[1:])
    ends = ((dense[0], problem.start), (dense[-1], problem.goal))
    ends_ok = all(np.allclose(a, b, atol=1e-6) for a, b in ends)
    dense[0], dense[-1] = problem.start.copy(), problem.goal.copy()
    if not ends_ok or any(problem.in_collision(q) for q in dense):
        return None, "planner output invalid after interpolation"
    return dense, reason


# ----------------------------------------------------------------------------- pybullet-planning


@contextlib.contextmanager
def _seeded_global_rngs(rng: np.random.Generator) -> Iterator[None]:
    """pybullet-planning draws from ``random`` and ``np.random`` (shuffles, shortcut choices);
    seed both from ``rng`` for the duration of the call and restore them afterwards."""
    py_state, np_state = random.getstate(), np.random.get_state()
    random.seed(int(rng.integers(2**63)))
    np.random.seed(int(rng.integers(2**32)))
    try:
        yield
    finally:
        random.setstate(py_state)
        np.random.set_state(np_state)


def _remove_redundant(path: Sequence[Config], tolerance: float = 1e-3) -> list[Config]:
    """pybullet-planning's ``remove_redundant``: drop each state within ``tolerance`` (every
    coordinate) of the last kept one. Its ``np.allclose(a, b, atol=t, rtol=0)`` is
    ``max |a - b| <= t`` for finite values, at a fifth of the cost."""
    kept = [path[0]]
    for q in path[1:]:
        if np.abs(np.asarray(kept[-1]) - np.asarray(q)).max() > tolerance:
            kept.append(q)
    return kept


def _unit(vector: np.ndarray) -> np.ndarray:
    norm = math.sqrt(vector.dot(vector))  # np.linalg.norm's own arithmetic for a vector
    return vector if norm == 0 else vector / norm


def _waypoints_from_path(path: Sequence[Config], difference_fn=None, tolerance: float = 1e-3) -> list[Config]:
    """pybullet-planning's ``waypoints_from_path`` (the states where a path turns), the same
    float operations without ``np.allclose``: it was a third of the shortcutting's own cost."""
    if difference_fn is not None:
        raise ValueError("only the default difference is supported")
    path = _remove_redundant(path, tolerance)
    if len(path) < 2:
        return path
    waypoints, last = [path[0]], path[1]
    last_direction = _unit(np.asarray(path[0]) - np.asarray(last))
    for q in path[2:]:
        direction = _unit(np.asarray(waypoints[-1]) - np.asarray(q))
        if np.abs(last_direction - direction).max() > tolerance:
            waypoints.append(last)
            direction = _unit(np.asarray(waypoints[-1]) - np.asarray(q))
        last, last_direction = q, direction
    waypoints.append(last)
    return waypoints


@contextlib.contextmanager
def _smoothing_fixes() -> Iterator[None]:
    """pybullet-planning's ``smooth_path`` with the faster, equal ``_waypoints_from_path`` and
    ``_remove_redundant`` for the duration of a call."""
    module = sys.modules["pybullet_planning.motion_planners.smoothing"]
    originals = module.waypoints_from_path, module.remove_redundant
    module.waypoints_from_path, module.remove_redundant = _waypoints_from_path, _remove_redundant
    try:
        yield
    finally:
        module.waypoints_from_path, module.remove_redundant = originals


def _pp_collision_fn(problem: PlanningProblem) -> Callable[..., bool]:
    # pybullet-planning's direct_path calls collision_fn(q, diagnosis=...).
    return lambda q, **_: problem.in_collision(q)


class _Tree:
    """An RRT tree: node configurations as rows of one growing array, and each node's parent."""

    def __init__(self, root: Config):
        self._configs = np.empty((64, root.shape[0]))
        self._configs[0] = root
        self._parents = [-1]

    def __len__(self) -> int:
        return len(self._parents)

    def config(self, node: int) -> Config:
        return self._configs[node]

    def configs(self) -> np.ndarray:
        return self._configs[:len(self)]

    def add(self, q: Config, parent: int) -> int:
        if len(self) == len(self._configs):
            self._configs = np.concatenate([self._configs, np.empty_like(self._configs)])
        self._configs[len(self)] = q
        self._parents.append(parent)
        return len(self) - 1

    def path_to(self, node: int) -> list[Config]:
        """Root .. node."""
        path = []
        while node >= 0:
            path.append(self._configs[node].copy())
            node = self._parents[node]
        return path[::-1]


def _extend_towards(problem: PlanningProblem, tree: _Tree, target: Config, backward: bool) -> tuple[int, bool]:
    """Add the collision-free prefix of the line from the nearest node towards ``target`` (the
    nearest node itself again first, as pybullet-planning does); the last node added (the
    nearest if none) and whether the whole line was free. ``backward``: the line is interpolated
    from ``target`` (the goal tree's motions run towards the goal)."""
    last = problem.nearest(tree.configs(), target)
    start = tree.config(last)
    states = problem.extend(target, start)[::-1] if backward else problem.extend(start, target)
    for q in states:
        if problem.in_collision(q):
            return last, False
        last = tree.add(q, last)
    return last, True


def rrt_connect(problem: PlanningProblem, sample: Callable[[], Config], iterations: int,
                deadline: float = math.inf) -> list[Config] | None:
    """pybullet-planning's ``rrt_connect`` (Kuffner and LaValle 2000) step for step: the same
    samples, trees and path; its nearest-neighbour scan called the distance once per node.
    ``deadline``: a ``time.perf_counter()`` value after which no iteration starts."""
    if problem.in_collision(problem.start) or problem.in_collision(problem.goal):
        return None
    trees = _Tree(problem.start), _Tree(problem.goal)
    for _ in range(iterations):
        if time.perf_counter() >= deadline:
            break
        swap = len(trees[0]) > len(trees[1])  # grow the smaller tree towards the sample
        tree1, tree2 = (trees[1], trees[0]) if swap else trees
        last1, _ = _extend_towards(problem, tree1, sample(), backward=swap)
        last2, connected = _extend_towards(problem, tree2, tree1.config(last1), backward=not swap)
        if connected:
            path1, path2 = tree1.path_to(last1), tree2.path_to(last2)
            if swap:
                path1, path2 = path2, path1
            return path1[:-1] + path2[::-1]
    return None


class PybulletRRTConnectPlanner(Planner):
    """pybullet-planning's ``birrt``: the direct path, then up to ``restarts + 1`` RRT-Connect
    runs, the first path found shortcut by its ``smooth_path``. Same seed, same path; faster."""

    backend = "rrt_connect"
    params: RRTConnectParams

    def _solve(self, problem, rng):
        from pybullet_planning.motion_planners import smooth_path

        p = self.params
        deadline = time.perf_counter() + p.max_time_s
        with _seeded_global_rngs(rng), _smoothing_fixes():
            direct = _direct_path(problem)  # birrt's first step (remembered if ``Planner`` tried it)
            if direct is not None:
                return direct, "direct connection"
            sample = problem.sample_fn(rng)
            for _ in range(p.restarts + 1):
                if time.perf_counter() >= deadline:
                    break
                path = rrt_connect(problem, sample, p.iterations, deadline)
                if path is not None:
                    # birrt's default cost, len(extend(q1, q2)), without building the states
                    path = smooth_path(path, problem.extend, _pp_collision_fn(problem),
                                       distance_fn=problem.extend_length,
                                       max_smooth_iterations=p.smoothing_iterations,
                                       max_time=deadline - time.perf_counter())
                    return path, "planned"
        return None, "no path found"


def _weighted_distance_fn(weights, p_norm=2) -> Callable[[Config, Config], float]:
    """pybullet-planning's weighted Euclidean distance in plain Python: Lazy PRM calls it for
    every edge of every graph search, and ``np.linalg.norm`` on 3-8 numbers costs about 4x more."""
    if p_norm != 2:
        raise ValueError(f"only the Euclidean norm is supported, got p_norm={p_norm}")
    w = [float(v) for v in weights]

    def distance(q1, q2) -> float:
        return math.sqrt(sum(((b - a) * k) ** 2 for a, b, k in zip(q1.tolist(), q2.tolist(), w)))

    return distance


@contextlib.contextmanager
def _lazy_prm_fixes() -> Iterator[None]:
    """Two patches of pybullet-planning 0.6.1's ``lazy_prm`` module for the duration of a call:

    * ``check_path`` visits vertices through ``random_selector``, which shuffles the candidate
      path *in place*: edges are then checked between wrong vertex pairs and a returned path can
      be a permutation that does not end at the goal. A copying shuffle replaces it.
    * its distance function (``_weighted_distance_fn``), the search's largest cost."""
    module = sys.modules["pybullet_planning.motion_planners.lazy_prm"]
    originals = module.random_selector, module.get_distance_fn
    module.random_selector = lambda path: random.sample(list(path), len(path))
    module.get_distance_fn = _weighted_distance_fn
    try:
        yield
    finally:
        module.random_selector, module.get_distance_fn = originals


class PybulletLazyPRMPlanner(Planner):
    backend = "lazy_prm"
    params: LazyPRMParams

    def _solve(self, problem, rng):
        # pybullet-planning's own `replan_loop` crashes on success (it unpacks lazy_prm's
        # 5-tuple into 4 names), so the size loop is done here.
        from pybullet_planning.motion_planners import lazy_prm, smooth_path

        p = self.params
        collision_fn = _pp_collision_fn(problem)
        start_time = time.perf_counter()
        with _seeded_global_rngs(rng), _lazy_prm_fixes(), _smoothing_fixes():
            for size in p.roadmap_sizes:
                remaining = p.max_time_s - (time.perf_counter() - start_time)
                if remaining <= 0:
                    return None, "time limit reached"
                path = lazy_prm(
                    problem.start, problem.goal, problem.sample_fn(rng), problem.extend, collision_fn,
                    num_samples=size, weights=1.0 / problem.resolutions, lazy=True,
                    max_time=remaining, max_degree=p.max_degree,
                )[0]
                if path is not None:
                    path = smooth_path(path, problem.extend, collision_fn, distance_fn=problem.distance,
                                       max_smooth_iterations=p.smoothing_iterations)
                    return path, f"planned (roadmap size {size})"
        return None, "no path found"


# ----------------------------------------------------------------------------- OMPL


@contextlib.contextmanager
def _ompl_log_level(level_name: str) -> Iterator[None]:
    from ompl import util as ou

    previous = ou.getLogLevel()
    ou.setLogLevel(getattr(ou.LogLevel, level_name))
    try:
        yield
    finally:
        ou.setLogLevel(previous)


class OMPLPlanner(Planner):
    """OMPL planning in resolution-scaled coordinates (``s = q / resolutions``).

    Scaling makes one unit equal one resolution step in every dimension, so OMPL's Euclidean
    motion checking at a segment length of 1 never skips more than a resolution step in any
    coordinate, whatever the mix of metres and radians.
    """

    def _make_ompl_planner(self, si):
        raise NotImplementedError

    def _solve(self, problem, rng):
        from ompl import base as ob, geometric as og, util as ou

        with _ompl_log_level("LOG_WARN"):
            with _ompl_log_level("LOG_NONE"):
                # OMPL complains that sampling already started, but it does reseed the seed
                # generator, so every RNG created afterwards (ours are all new) is deterministic.
                ou.RNG.setSeed(int(rng.integers(1, 2**31 - 1)))
            scale = problem.resolutions
            space = ob.RealVectorStateSpace(problem.dimension)
            bounds = ob.RealVectorBounds(problem.dimension)
            for i in range(problem.dimension):
                bounds.setLow(i, float(problem.lower[i] / scale[i]))
                bounds.setHigh(i, float(problem.upper[i] / scale[i]))
            space.setBounds(bounds)
            dim = problem.dimension

            def to_config(state) -> Config:
                return np.asarray(state[0:dim], dtype=np.float64) * scale

            def to_state(q: Config):
                state = space.allocState()
                state[0:dim] = [float(v) for v in q / scale]
                return state

            setup = og.SimpleSetup(space)
            setup.setStateValidityChecker(lambda state: not problem.in_collision(to_config(state)))
            si = setup.getSpaceInformation()
            si.setStateValidityCheckingResolution(1.0 / space.getMaximumExtent())
            if problem.has_custom_extend:
                si.setMotionValidator(_make_extend_motion_validator(ob, si, problem, to_config))
            setup.setStartAndGoalStates(to_state(problem.start), to_state(problem.goal))
            setup.setPlanner(self._make_ompl_planner(si))
            status = setup.solve(float(self.params.time_limit_s))
            if not setup.haveExactSolutionPath():
                return None, f"no path found (OMPL: {status.asString()})"
            solution = setup.getSolutionPath()
            if self.params.simplify_steps > 0:
                simplifier = og.PathSimplifier(si)
                simplifier.reduceVertices(solution, self.params.simplify_steps)
                simplifier.partialShortcutPath(solution, self.params.simplify_steps)
                simplifier.collapseCloseVertices(solution, self.params.simplify_steps)
            path = [to_config(s) for s in solution.getStates()]
        return path, "planned"


def _make_extend_motion_validator(ob, si, problem: PlanningProblem, to_config):
    """A Python MotionValidator that checks segments along the problem's own extension."""

    class ExtendMotionValidator(ob.MotionValidator):
        def checkMotion(self, s1, s2) -> bool:  # noqa: N802 (OMPL's name)
            segment = problem.extend(to_config(s1), to_config(s2))
            return not any(problem.in_collision(q) for q in segment[1:])

    return ExtendMotionValidator(si)


class OMPLRRTConnectPlanner(OMPLPlanner):
    backend = "ompl_rrtconnect"
    params: OMPLRRTConnectParams

    def _make_ompl_planner(self, si):
        from ompl import geometric as og

        planner = og.RRTConnect(si)
        if self.params.range > 0:
            planner.setRange(float(self.params.range))
        return planner


class OMPLPRMPlanner(OMPLPlanner):
    backend = "ompl_prm"
    params: OMPLPRMParams

    def _make_ompl_planner(self, si):
        from ompl import geometric as og

        planner = og.PRM(si)
        planner.setMaxNearestNeighbors(int(self.params.max_nearest_neighbors))
        return planner


# ----------------------------------------------------------------------------- registry


BACKENDS: dict[str, tuple[type[Planner], type]] = {
    "rrt_connect": (PybulletRRTConnectPlanner, RRTConnectParams),
    "lazy_prm": (PybulletLazyPRMPlanner, LazyPRMParams),
    "ompl_rrtconnect": (OMPLRRTConnectPlanner, OMPLRRTConnectParams),
    "ompl_prm": (OMPLPRMPlanner, OMPLPRMParams),
}


def make_planner(name: str, params: Any | None = None, **overrides: Any) -> Planner:
    """A planner by backend name; ``params`` (the backend's dataclass) and/or keyword overrides."""
    if name not in BACKENDS:
        raise ValueError(f"unknown planner backend {name!r}; valid: {sorted(BACKENDS)}")
    planner_cls, params_cls = BACKENDS[name]
    params = params if params is not None else params_cls()
    if not isinstance(params, params_cls):
        raise TypeError(f"{name} expects {params_cls.__name__}, got {type(params).__name__}")
    if overrides:
        params = dataclasses.replace(params, **overrides)
    return planner_cls(params)
