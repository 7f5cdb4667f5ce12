"""Scene construction: names, layouts, PyBullet agreement, determinism, house semantics."""

import math

import numpy as np
import pybullet as p
import pytest

from relmogen.scenes import ROBOT_RADIUS, available_scenes, make_scene

OFFICES = ["office_A", "office_B"]
HOUSES = ["house_A", "house_B"]


@pytest.fixture
def client():
    cid = p.connect(p.DIRECT)
    yield cid
    p.disconnect(cid)


def test_available_scenes():
    assert set(available_scenes()) == {"office_A", "office_B", "house_A", "house_B"}


def test_unknown_name_lists_valid_names(client):
    with pytest.raises(ValueError) as err:
        make_scene("office_Z", client)
    for name in available_scenes():
        assert name in str(err.value)


@pytest.mark.parametrize("name", available_scenes())
def test_scene_builds_with_few_static_bodies(client, name):
    scene = make_scene(name, client, seed=0)
    assert scene.name == name
    assert 0 < len(scene.static_body_ids) <= 20
    assert p.getNumBodies(physicsClientId=client) >= len(scene.static_body_ids)
    assert scene.floor_body_id in scene.static_body_ids
    for region in scene.regions.values():
        assert scene.bounds.contains(region.center)


def _signature(scene):
    return (sorted(scene.regions), [d.center for d in scene.doorways], scene.bounds)


@pytest.mark.parametrize("pair", [OFFICES, HOUSES])
def test_a_and_b_differ(client, pair):
    a, b = (make_scene(n, client) for n in pair)
    assert _signature(a) != _signature(b)


@pytest.mark.parametrize("name", OFFICES)
def test_office_dimensions_and_goal_doorway(client, name):
    scene = make_scene(name, client)
    corridor = scene.regions["corridor"]
    assert 1.8 <= min(corridor.size) <= 2.2
    for d in scene.doorways:
        assert 0.9 <= d.width <= 1.1
        assert 0.1 <= d.wall_thickness <= 0.15
    rooms = [r for n, r in scene.regions.items() if n != "corridor"]
    assert all(3.8 <= min(r.size) and max(r.size) <= 7.5 for r in rooms)
    door = scene.goal_doorway
    assert door is not None and door.regions == (scene.start_region, scene.goal_region)
    assert scene.doorways_of(scene.goal_region) == [door]  # the door closes the goal room off
    assert scene.region_of(door.point_in_front(scene.goal_region, 0.6)) == scene.goal_region
    assert scene.region_of(door.point_in_front(scene.start_region, 0.6)) == scene.start_region


@pytest.mark.parametrize("name", available_scenes())
def test_every_region_reachable_on_the_field(client, name):
    scene = make_scene(name, client)
    rng = np.random.default_rng(0)
    field = scene.geodesic_field(scene.sample_free_point(rng))
    for region in scene.regions:
        assert math.isfinite(field.distance(scene.sample_free_point(rng, region))), region


def _probe_hits(scene, client, xy) -> np.ndarray:
    """Whether a thin vertical probe (z 0.1 to 1.5 m) at each xy touches a non-floor static body.

    (Rays are no good here: a ray starting inside a wall reports no hit.)
    """
    shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.001, 0.001, 0.7], physicsClientId=client)
    probe = p.createMultiBody(0, shape, -1, [0, 0, -10], physicsClientId=client)
    bodies = [b for b in scene.static_body_ids if b != scene.floor_body_id]
    hits = []
    for x, y in xy:
        p.resetBasePositionAndOrientation(probe, [x, y, 0.8], [0, 0, 0, 1], physicsClientId=client)
        hits.append(any(p.getClosestPoints(probe, b, 0.0, physicsClientId=client) for b in bodies))
    p.removeBody(probe, physicsClientId=client)
    return np.array(hits)


def _clear_of_box_edges(scene, xy, tol=0.005) -> np.ndarray:
    """Points farther than `tol` from every box outline (the probe's touch test is ambiguous there)."""
    ok = np.ones(len(xy), dtype=bool)
    for bx in scene.layout.boxes:
        r = bx.footprint
        inside_x = (xy[:, 0] > r.xmin - tol) & (xy[:, 0] < r.xmax + tol)
        inside_y = (xy[:, 1] > r.ymin - tol) & (xy[:, 1] < r.ymax + tol)
        near_x = (np.abs(xy[:, 0] - r.xmin) < tol) | (np.abs(xy[:, 0] - r.xmax) < tol)
        near_y = (np.abs(xy[:, 1] - r.ymin) < tol) | (np.abs(xy[:, 1] - r.ymax) < tol)
        ok &= ~((near_x & inside_y) | (near_y & inside_x))
    return ok


@pytest.mark.parametrize("name", available_scenes())
def test_traversability_agrees_with_pybullet(client, name):
    scene = make_scene(name, client)
    rng = np.random.default_rng(1)
    b = scene.bounds
    xy = rng.uniform((b.xmin, b.ymin), (b.xmax, b.ymax), size=(1000, 2))
    xy = xy[_clear_of_box_edges(scene, xy)]
    hit, free = _probe_hits(scene, client, xy), scene.trav_map.is_free(xy)
    assert hit.any() and free.any()
    assert not np.any(hit & free)
    assert np.mean(~hit & ~free) < 0.05  # conservative rasterisation adds only a thin margin


@pytest.mark.parametrize("name", available_scenes())
def test_walls_blocked_and_openings_free(client, name):
    scene = make_scene(name, client)
    for d in scene.doorways:
        assert scene.trav_map.is_free(d.center)
        assert not scene.trav_map.is_free(np.asarray(d.center) + (0.5 * d.width + 0.2) * d.along)
    walls = [bx for bx in scene.layout.boxes if bx.kind == "wall" and bx.z_range[0] == 0.0]
    assert not any(scene.trav_map.is_free(w.center[:2]) for w in walls)


@pytest.mark.parametrize("name", available_scenes())
def test_same_seed_same_scene_and_samples(client, name):
    a, b = make_scene(name, client, seed=3), make_scene(name, client, seed=3)
    assert a.layout.boxes == b.layout.boxes
    sa = a.sample_start_goal(np.random.default_rng(7))
    sb = b.sample_start_goal(np.random.default_rng(7))
    np.testing.assert_array_equal(sa.start_xy, sb.start_xy)
    np.testing.assert_array_equal(sa.goal_xy, sb.goal_xy)
    assert sa.start_yaw == sb.start_yaw
    assert make_scene(name, client, seed=4).layout.boxes != a.layout.boxes


@pytest.mark.parametrize("name", HOUSES)
def test_dining_table_leaves_chair_gaps(client, name):
    scene = make_scene(name, client)
    t = scene.table
    assert scene.region_of(t.center) == "dining"
    assert abs(t.height - 0.75) < 0.02 and len(t.leg_positions) >= 4
    assert len(t.side_gaps) >= 2
    for _, _, gap in t.side_gaps:
        assert 0.55 <= gap <= 0.65
    lo, hi = p.getAABB(t.body_id, physicsClientId=client)
    assert abs(hi[2] - t.height) < 1e-3
    fp = t.footprint
    assert abs((hi[0] - lo[0]) - fp.size[0]) < 1e-3 and abs((hi[1] - lo[1]) - fp.size[1]) < 1e-3


@pytest.mark.parametrize("name", HOUSES)
def test_kitchen_walls_face_into_the_kitchen(client, name):
    scene = make_scene(name, client)
    kitchen = scene.regions["kitchen"]
    assert len(scene.kitchen_walls) == 3
    for seg in scene.kitchen_walls:
        assert seg.length >= 3.5
        inside = seg.point_at(0.5 * seg.length) + 0.3 * np.array([math.cos(seg.normal_yaw), math.sin(seg.normal_yaw)])
        assert kitchen.contains(inside)
        opening = np.asarray(scene.doorways_of("kitchen")[0].center)
        along = np.clip(np.dot(opening - seg.start, seg.direction), 0.0, seg.length)
        assert np.linalg.norm(opening - seg.point_at(along)) > 0.5  # no free wall runs through the opening


@pytest.mark.parametrize("name", HOUSES)
def test_tabletop_spots_face_the_reach_table(client, name):
    scene = make_scene(name, client)
    table = scene.reach_table
    free = scene.trav_map.eroded(ROBOT_RADIUS)
    for x, y, yaw in scene.tabletop_spots:
        assert free.is_free((x, y))
        to_table = np.subtract(table.center, (x, y))
        heading = np.array([math.cos(yaw), math.sin(yaw)])
        assert np.dot(to_table, heading) / np.linalg.norm(to_table) > 0.8
        assert not table.footprint.shrunk(-0.45).contains((x, y))
        assert table.footprint.shrunk(-0.55).contains((x, y))
