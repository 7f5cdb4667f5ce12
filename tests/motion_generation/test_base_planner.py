"""Base planner on synthetic local maps, for every planner backend."""

from __future__ import annotations

import numpy as np
import pytest
from mg_maps import ROBOT_POSE, cluttered_map, doorway_map, empty_map, random_free_goal

from relmogen.motion_generation.base_planner import (
    BASE_STEP_M,
    BASE_STEP_RAD,
    FETCH_FOOTPRINT_RADIUS,
    FootprintChecker,
    base_distance_fn,
    base_extend_fn,
    base_planning_problem,
    make_base_planner,
    plan_base,
    wrap_angle,
)
from relmogen.motion_generation.planners import BACKENDS, make_planner
from relmogen.simulation.frames import to_local
from relmogen.simulation.occupancy import OCCUPIED, UNKNOWN, LocalMap

ALL_BACKENDS = sorted(BACKENDS)
TOL = 1e-6


def assert_valid_path(local_map: LocalMap, result, goal_robot) -> None:
    assert result.success, result.reason
    path = result.path_world
    assert path.ndim == 2 and path.shape[1] == 3
    start_world = np.array(local_map.robot_pose)
    goal_world = np.array([*local_map.robot_to_world(np.asarray(goal_robot[:2])),
                           wrap_angle(goal_robot[2] + local_map.robot_pose[2])])
    np.testing.assert_allclose(path[0], start_world, atol=TOL)
    np.testing.assert_allclose(path[-1, :2], goal_world[:2], atol=TOL)
    assert abs(wrap_angle(path[-1, 2] - goal_world[2])) < TOL
    steps = np.diff(path, axis=0)
    assert np.all(np.hypot(steps[:, 0], steps[:, 1]) <= BASE_STEP_M + TOL)
    assert np.all(np.abs(wrap_angle(steps[:, 2])) <= BASE_STEP_RAD + TOL)
    # Every waypoint's footprint is free (re-expressed in the robot frame at scan time).
    checker = FootprintChecker(local_map, FETCH_FOOTPRINT_RADIUS)
    for xy in local_map.world_to_robot(path[:, :2]):
        assert not checker.in_collision(np.array([xy[0], xy[1], 0.0]))
    driven = np.sum(np.hypot(steps[:, 0], steps[:, 1]))
    assert result.path_length_m == pytest.approx(driven)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_empty_room_plans_straight(backend):
    local_map, goal = empty_map(), np.array([1.8, -1.2, 2.5])
    result = plan_base(local_map, goal, make_planner(backend), rng=0)
    assert_valid_path(local_map, result, goal)
    assert result.reason == "direct connection"
    assert result.path_length_m == pytest.approx(np.hypot(1.8, -1.2))


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_doorway(backend):
    local_map, goal = doorway_map(), np.array([2.0, -1.0, 0.0])
    # OMPL stops on wall-clock time: give it room on a loaded CI machine.
    planner = make_base_planner(backend, time_limit_s=5.0) if backend.startswith("ompl") else backend
    result = plan_base(local_map, goal, planner, rng=1)
    assert_valid_path(local_map, result, goal)
    assert result.path_length_m > np.hypot(2.0, -1.0)  # had to detour through the gap


@pytest.mark.parametrize("backend", ALL_BACKENDS)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cluttered_room(backend, seed):
    rng = np.random.default_rng(100 + seed)
    local_map = cluttered_map(rng)
    goal = random_free_goal(local_map, rng)
    result = plan_base(local_map, goal, backend, rng=seed)
    assert_valid_path(local_map, result, goal)


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_rotation_in_place_returns_immediately(backend):
    local_map, goal = doorway_map(), np.array([0.0, 0.0, -2.0])
    result = plan_base(local_map, goal, backend, rng=0)
    assert_valid_path(local_map, result, goal)
    assert result.reason == "rotation in place"
    assert result.path_length_m == 0.0
    assert len(result.path_world) == int(np.ceil(2.0 / BASE_STEP_RAD)) + 1


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_start_touching_obstacle_can_leave(backend):
    local_map = empty_map()
    grid = local_map.grid.copy()
    x = local_map.cell_to_point(np.arange(local_map.size))
    grid[(x > 0.22) & (x < 0.4), :] = OCCUPIED  # wall 0.22 m ahead: inside the 0.279 m disc
    local_map = LocalMap(grid, local_map.resolution, local_map.robot_pose)
    checker = FootprintChecker(local_map, FETCH_FOOTPRINT_RADIUS)
    assert checker.footprint_hits_obstacle(np.zeros(3))
    goal = np.array([-1.5, 0.5, 0.0])
    result = plan_base(local_map, goal, backend, rng=0)
    assert_valid_path(local_map, result, goal)
    # ...but may not push further into the wall.
    assert checker.in_collision(np.array([0.1, 0.0, 0.0]))


def test_unknown_counts_as_obstacle_except_under_robot():
    grid = np.full((100, 100), UNKNOWN, dtype=np.uint8)
    local_map = LocalMap(grid, 0.05, ROBOT_POSE)
    checker = FootprintChecker(local_map, FETCH_FOOTPRINT_RADIUS)
    assert not checker.in_collision(np.zeros(3))
    result = plan_base(local_map, np.array([1.0, 0.0, 0.0]), "rrt_connect", rng=0)
    assert not result.success and result.reason == "goal in collision"


@pytest.mark.parametrize("backend", ALL_BACKENDS)
@pytest.mark.parametrize(
    ("goal", "reason"),
    [((3.0, 0.0, 0.0), "goal outside local map"), ((1.0, -1.0, 0.0), "goal in collision")],
)
def test_bad_goal_fails_at_once(backend, goal, reason, monkeypatch):
    planner = make_base_planner(backend)
    monkeypatch.setattr(planner, "plan", lambda *a, **k: pytest.fail("the planner must not be called"))
    result = plan_base(doorway_map(), np.array(goal), planner, rng=0)
    assert not result.success and result.path_world is None
    assert result.reason == reason


@pytest.mark.parametrize("backend", ALL_BACKENDS)
def test_a_goal_walled_off_from_the_robot_fails_without_a_search(backend, monkeypatch):
    closed_door = doorway_map(gap=0.0)
    goal = np.array([2.0, -1.0, 0.0])  # free, behind the wall
    assert not FootprintChecker(closed_door, FETCH_FOOTPRINT_RADIUS).in_collision(goal)
    planner = make_base_planner(backend)
    monkeypatch.setattr(planner, "plan", lambda *a, **k: pytest.fail("the planner must not be called"))
    result = plan_base(closed_door, goal, planner, rng=0)
    assert not result.success and result.reason == "goal not connected to the robot on the local map"


@pytest.mark.parametrize("seed", range(6))
def test_the_connectivity_check_never_refuses_a_goal_a_planner_reaches(seed):
    rng = np.random.default_rng(200 + seed)
    local_map = cluttered_map(rng, n_obstacles=30)
    checker = FootprintChecker(local_map, FETCH_FOOTPRINT_RADIUS)
    problem_goals = [random_free_goal(local_map, rng) for _ in range(5)]
    for goal in problem_goals:
        searched = make_planner("rrt_connect").plan(base_planning_problem(local_map, goal, checker), rng=seed)
        if searched.success:
            assert checker.connected_to_start(goal)
        else:
            assert plan_base(local_map, goal, "rrt_connect", rng=seed).success is False


@pytest.mark.parametrize("backend", ["rrt_connect", "lazy_prm", "ompl_rrtconnect"])
def test_same_seed_same_path(backend):
    local_map, goal = doorway_map(), np.array([2.0, -1.0, 1.0])
    first = plan_base(local_map, goal, backend, rng=7)
    second = plan_base(local_map, goal, backend, rng=7)
    np.testing.assert_array_equal(first.path_world, second.path_world)


def test_extend_fn_rotates_drives_rotates():
    path = np.array(base_extend_fn()(np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, np.pi])))
    heading_reached = np.flatnonzero(np.isclose(path[:, 2], np.pi / 2))[0]
    assert np.allclose(path[: heading_reached + 1, :2], 0.0)  # turn on the spot first
    assert np.allclose(path[heading_reached:-1, 0], 0.0)  # then drive along +y
    assert np.isclose(path[-1, 2], np.pi) or np.isclose(path[-1, 2], -np.pi)
    distance = base_distance_fn()(np.zeros(3), np.array([0.0, 1.0, np.pi]))
    assert distance == pytest.approx(1.0 + np.pi / 2 + np.pi / 2)


@pytest.mark.parametrize("backend", ["rrt_connect", "lazy_prm"])
def test_nearest_free_drives_a_goal_in_the_wall_back_to_the_free_pose_in_front_of_it(backend):
    local_map = doorway_map(wall_x=1.5, gap_centre_y=2.0, gap=0.5)  # the wall is closed in front of the robot
    goal = np.array([1.5, 0.0, 0.7])
    assert plan_base(local_map, goal, backend, rng=0).reason == "goal in collision"
    result = plan_base(local_map, goal, backend, rng=0, goal_mode="nearest_free")
    end = result.path_world[-1]
    stop_x = 1.5 - 0.05 - FETCH_FOOTPRINT_RADIUS  # the wall's near face minus the footprint
    assert result.success and result.reason.startswith("goal in collision, moved")
    driven = float(np.hypot(*(end[:2] - np.array(ROBOT_POSE[:2]))))  # straight along the robot's x axis
    assert stop_x - 2 * BASE_STEP_M <= driven <= stop_x + BASE_STEP_M  # clearance is read per 0.05 m cell
    assert abs(wrap_angle(end[2] - ROBOT_POSE[2] - 0.7)) < TOL


def test_nearest_free_with_the_line_blocked_beyond_the_blind_zone_stays_in_it():
    grid = np.full((100, 100), UNKNOWN, dtype=np.uint8)
    result = plan_base(LocalMap(grid, 0.05, ROBOT_POSE), np.array([1.0, 0.0, 1.0]), "rrt_connect", rng=0,
                       goal_mode="nearest_free")
    # only the robot's own blind zone is free: it may move within it, never beyond
    assert result.success and result.path_length_m <= FETCH_FOOTPRINT_RADIUS + 0.3


@pytest.mark.parametrize("backend", ["rrt_connect", "lazy_prm"])
def test_nearest_reachable_drives_a_goal_walled_off_from_the_robot_to_the_wall(backend):
    closed_door = doorway_map(gap=0.0)
    goal = np.array([2.0, -1.0, 0.3])  # free, behind the wall at x = 1
    assert plan_base(closed_door, goal, backend, rng=0, goal_mode="nearest_free").reason == (
        "goal not connected to the robot on the local map")
    result = plan_base(closed_door, goal, backend, rng=0, goal_mode="nearest_reachable")
    assert result.success and result.reason.startswith("goal unreachable, moved")
    end_robot = to_local(result.path_world[-1][:2], ROBOT_POSE)
    assert abs(end_robot[0] * goal[1] - end_robot[1] * goal[0]) < 1e-6  # on the line to the goal
    assert 1.0 - 0.05 - FETCH_FOOTPRINT_RADIUS - 2 * BASE_STEP_M <= end_robot[0] <= 1.0 - FETCH_FOOTPRINT_RADIUS
    assert abs(wrap_angle(result.path_world[-1][2] - ROBOT_POSE[2] - 0.3)) < TOL


def test_nearest_reachable_keeps_a_reachable_goal():
    goal = np.array([1.5, 0.5, 0.0])
    result = plan_base(empty_map(), goal, "rrt_connect", rng=0, goal_mode="nearest_reachable")
    assert result.success and "moved" not in result.reason
    assert np.allclose(to_local(result.path_world[-1][:2], ROBOT_POSE), goal[:2], atol=1e-6)


def test_an_unknown_goal_mode_is_refused():
    with pytest.raises(ValueError, match="goal_mode"):
        plan_base(empty_map(), np.array([1.0, 0.0, 0.0]), "rrt_connect", goal_mode="loose")


@pytest.mark.parametrize("goal_mode", ["nearest_free", "nearest_reachable"])
def test_goal_clearance_stops_the_base_that_much_farther_from_the_wall(goal_mode):
    local_map = doorway_map(wall_x=1.5, gap_centre_y=2.0, gap=0.5)
    goal = np.array([1.5, 0.0, 0.0])

    def stop_distance(clearance: float) -> float:
        result = plan_base(local_map, goal, "rrt_connect", rng=0, goal_mode=goal_mode, goal_clearance=clearance)
        assert result.success and "moved" in result.reason
        return float(to_local(result.path_world[-1][:2], ROBOT_POSE)[0])

    assert stop_distance(0.0) - stop_distance(0.2) == pytest.approx(0.2, abs=BASE_STEP_M + TOL)


def test_goal_clearance_refuses_a_free_goal_near_the_wall_in_strict_mode_and_keeps_one_far_from_it():
    local_map = doorway_map(wall_x=1.5, gap_centre_y=2.0, gap=0.5)
    near_wall = np.array([1.5 - 0.05 - FETCH_FOOTPRINT_RADIUS - 0.1, 0.0, 0.0])  # 5 cm clear of the wall's face
    assert plan_base(local_map, near_wall, "rrt_connect", rng=0).success
    assert plan_base(local_map, near_wall, "rrt_connect", rng=0, goal_clearance=0.15).reason == "goal in collision"
    far = np.array([0.5, 0.0, 0.0])
    assert plan_base(local_map, far, "rrt_connect", rng=0, goal_clearance=0.15).success


def test_goal_clearance_never_refuses_a_rotation_in_place():
    next_to_wall = doorway_map(wall_x=FETCH_FOOTPRINT_RADIUS + 0.1, gap_centre_y=2.0, gap=0.5)
    result = plan_base(next_to_wall, np.array([0.0, 0.0, 1.0]), "rrt_connect", rng=0, goal_clearance=0.3)
    assert result.success and result.reason == "rotation in place"


@pytest.mark.parametrize("clearance", [-0.1, float("nan")])
def test_a_bad_goal_clearance_is_refused(clearance):
    with pytest.raises(ValueError, match="goal_clearance"):
        plan_base(empty_map(), np.array([1.0, 0.0, 0.0]), "rrt_connect", goal_clearance=clearance)
