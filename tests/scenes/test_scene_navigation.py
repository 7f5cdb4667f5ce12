"""Traversability map and geodesic field on synthetic maps and on real scenes."""

import math

import numpy as np
import pybullet as p
import pytest

from relmogen.scenes import (ROBOT_RADIUS, GeodesicField, Rect, TraversabilityMap, make_scene,
                             sample_start_goal)

ROOM = Rect(0.0, 0.0, 10.0, 6.0)
WALL_WITH_GAP = Rect(4.94, 0.0, 5.06, 4.5)  # from the south wall up to y = 4.5; gap above


@pytest.fixture
def client():
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(cid)


def empty_room():
    return TraversabilityMap.from_rects(ROOM, [])


def room_with_wall():
    return TraversabilityMap.from_rects(ROOM, [WALL_WITH_GAP])


def test_world_cell_round_trip():
    m = empty_room()
    xy = np.array([[0.025, 0.025], [3.33, 4.71], [9.97, 5.99]])
    np.testing.assert_allclose(m.cell_to_world(m.world_to_cell(xy)), xy, atol=m.resolution / 2 + 1e-9)
    assert m.resolution == 0.05


def test_eroded_map_keeps_robot_radius_from_walls():
    m = room_with_wall()
    e = m.eroded(ROBOT_RADIUS)
    assert e.is_free((2.0, 3.0)) and not e.is_free((5.0 - 0.2, 2.0)) and not e.is_free((0.2, 3.0))
    assert m.is_free((5.0 - 0.2, 2.0)) and not m.is_free((5.0, 2.0))


@pytest.mark.parametrize("start, goal", [((2.0, 3.0), (8.0, 3.0)), ((1.5, 1.5), (8.5, 4.5)),
                                         ((1.0, 5.0), (6.0, 1.2))])
def test_geodesic_equals_straight_line_in_empty_room(start, goal):
    field = GeodesicField(empty_room(), goal)
    straight = math.dist(start, goal)
    assert field.distance(start) == pytest.approx(straight, rel=0.03)
    assert field.distance(goal) < 0.05


def test_geodesic_goes_around_a_wall():
    start, goal = (3.0, 1.0), (7.0, 1.0)
    field = GeodesicField(room_with_wall(), goal)
    must_pass_above = 2 * math.hypot(2.0, 3.5)  # any path crosses x = 5 at y >= 4.5
    assert field.distance(start) > must_pass_above
    assert field.distance(start) < 1.15 * must_pass_above
    assert GeodesicField(empty_room(), goal).distance(start) < 0.6 * field.distance(start)


def test_vectorised_distance_matches_scalar():
    field = GeodesicField(room_with_wall(), (7.0, 1.0))
    pts = np.random.default_rng(0).uniform((0.5, 0.5), (9.5, 5.5), size=(50, 2))
    np.testing.assert_allclose(field.distances(pts), [field.distance(q) for q in pts])


def test_unreachable_goal_is_inf():
    closed = [Rect(6.0, 0.0, 6.12, 6.0)]  # full-height wall splits the room
    field = GeodesicField(TraversabilityMap.from_rects(ROOM, closed), (8.0, 3.0))
    assert field.distance((2.0, 3.0)) == math.inf
    assert math.isfinite(field.distance((9.0, 3.0)))
    np.testing.assert_array_equal(field.waypoints((2.0, 3.0), n=3), np.tile((8.0, 3.0), (3, 1)))


def test_points_near_walls_snap_to_free_space():
    field = GeodesicField(room_with_wall(), (7.0, 3.0))
    near_wall = (5.2, 2.0)  # inside the robot-radius band around the wall
    assert math.isfinite(field.distance(near_wall))
    assert field.distance(near_wall) == pytest.approx(math.dist(near_wall, (7.0, 3.0)), rel=0.1)


def _check_waypoints(field, free_map, start, n=10, spacing=0.2):
    w = field.waypoints(start, n=n, spacing=spacing)
    assert w.shape == (n, 2)
    chain = np.vstack([start, w])
    steps = np.linalg.norm(np.diff(chain, axis=0), axis=1)
    moving = steps > 1e-9
    assert np.all(steps[moving] <= spacing + 1e-6)
    assert np.all(steps[moving][:-1] >= 0.9 * spacing)  # the last step may end on the goal
    assert np.all(free_map.is_free(w))
    d = [field.distance(q) for q in chain]
    assert np.all(np.diff(d) < 0) or np.allclose(w[-1], field.goal_xy)
    return w


def test_waypoints_follow_the_path_around_the_wall():
    m = room_with_wall()
    field = GeodesicField(m, (7.0, 1.0))
    start = (3.0, 1.0)
    xy, d0 = np.asarray(start), field.distance(start)
    for _ in range(6):  # walk the whole path, 10 waypoints at a time
        w = _check_waypoints(field, m.eroded(ROBOT_RADIUS - 0.05), xy)
        xy = w[-1]
    assert field.distance(xy) < 0.1
    assert d0 > 8.0


def test_waypoints_pad_with_goal_near_goal():
    field = GeodesicField(empty_room(), (5.0, 3.0))
    w = field.waypoints((4.5, 3.0), n=10, spacing=0.2)
    np.testing.assert_allclose(w[:2], [[4.7, 3.0], [4.9, 3.0]], atol=2e-3)
    np.testing.assert_array_equal(w[3:], np.tile((5.0, 3.0), (7, 1)))


def test_start_goal_sampling_respects_range_and_determinism():
    m = room_with_wall()
    for seed in range(5):
        sg = sample_start_goal(m, np.random.default_rng(seed), min_geodesic=3.0, max_geodesic=6.0)
        assert 3.0 <= sg.geodesic_distance <= 6.0
        assert sg.field.distance(sg.start_xy) == pytest.approx(sg.geodesic_distance)
        assert m.eroded(ROBOT_RADIUS).is_free(sg.start_xy) and m.eroded(ROBOT_RADIUS).is_free(sg.goal_xy)
        again = sample_start_goal(m, np.random.default_rng(seed), min_geodesic=3.0, max_geodesic=6.0)
        np.testing.assert_array_equal(sg.start_xy, again.start_xy)


@pytest.mark.parametrize("name", ["office_A", "office_B"])
def test_scene_start_goal_in_regions(client, name):
    scene = make_scene(name, client)
    rng = np.random.default_rng(0)
    for _ in range(10):
        sg = scene.sample_start_goal(rng, 1.0, 10.0, scene.start_region, scene.goal_region)
        assert 1.0 <= sg.geodesic_distance <= 10.0
        assert scene.region_of(sg.start_xy) == scene.start_region
        assert scene.region_of(sg.goal_xy) == scene.goal_region
        assert sg.geodesic_distance >= np.linalg.norm(sg.goal_xy - sg.start_xy) - 0.05
        _check_waypoints(sg.field, scene.trav_map.eroded(ROBOT_RADIUS - 0.05), sg.start_xy)


def test_unknown_region_errors(client):
    scene = make_scene("office_A", client)
    with pytest.raises(ValueError, match="corridor"):
        scene.sample_free_point(np.random.default_rng(0), "kitchen")
