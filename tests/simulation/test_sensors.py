import numpy as np
import pybullet as p
import pytest

from relmogen.simulation.sensors import INVALID_DEPTH, Camera, CameraIntrinsics, Lidar
from relmogen.simulation.world import World


@pytest.fixture
def world():
    w = World()
    yield w
    w.close()


def add_box(client, xyz, half, rgba=(1, 0, 0, 1)):
    col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=client)
    vis = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=rgba, physicsClientId=client)
    return p.createMultiBody(0, col, vis, basePosition=xyz, physicsClientId=client)


def yaw_rotation(yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def test_intrinsics_of_a_90_degree_camera():
    k = CameraIntrinsics(128, 128, 90.0)
    assert k.fx == pytest.approx(64.0)
    assert (k.cx, k.cy) == (64.0, 64.0)


@pytest.mark.parametrize("u,v,depth", [(0, 0, 1.0), (64, 64, 2.0), (100, 17, 0.7), (127, 127, 2.9)])
def test_deproject_project_round_trip(u, v, depth):
    k = CameraIntrinsics(128, 128, 90.0)
    point = k.deproject(u, v, depth)
    assert point[0] == pytest.approx(depth)
    assert k.project(point) == pytest.approx((u, v, depth))


def test_pixel_plus_depth_lands_on_the_rendered_surface(world):
    # a wall facing the camera 1.5 m ahead: every deprojected pixel lies on its face
    add_box(world.client, [2.0, 0.0, 1.0], [0.5, 3.0, 3.0])
    camera = Camera(world.client)
    position, rotation = np.array([0.0, 0.0, 1.0]), yaw_rotation(0.3)
    frame = camera.capture(position, rotation)
    for u, v in [(64, 64), (10, 20), (120, 100), (64, 5)]:
        point = camera.pixel_to_world(frame, u, v)
        assert point[0] == pytest.approx(1.5, abs=0.02)
        # and the point projects back to the same pixel
        local = rotation.T @ (point - position)
        pu, pv, _ = camera.intrinsics.project(local)
        assert (pu, pv) == pytest.approx((u, v), abs=1e-6)


def test_out_of_range_depth_reads_invalid_and_cannot_be_deprojected(world):
    add_box(world.client, [0.2, 0.0, 1.0], [0.05, 0.5, 0.5])  # 0.15 m away: too near
    camera = Camera(world.client)
    frame = camera.capture(np.array([0.0, 0.0, 1.0]), np.eye(3))
    assert frame.depth.dtype == np.float32 and frame.rgb.dtype == np.uint8
    assert frame.depth[64, 64] == INVALID_DEPTH
    assert frame.depth[0, 0] == INVALID_DEPTH  # nothing there at all (beyond 3 m)
    with pytest.raises(ValueError, match="outside"):
        camera.pixel_to_world(frame, 200, 3)


def test_a_surface_nearer_than_the_sensor_range_still_has_points_but_empty_space_has_none(world):
    """The original's arm subgoal came from iGibson's unclipped 3D render: a door 0.15 m ahead
    has no depth reading but its points can still be reached for."""
    add_box(world.client, [0.2, 0.0, 1.0], [0.05, 0.5, 0.5])  # face 0.15 m ahead
    camera = Camera(world.client)
    frame = camera.capture(np.array([0.0, 0.0, 1.0]), np.eye(3))
    assert frame.depth[64, 64] == INVALID_DEPTH and frame.has_point(64, 64)
    assert camera.pixel_to_world(frame, 64, 64)[0] == pytest.approx(0.15, abs=0.01)
    empty = camera.capture(np.array([0.0, 0.0, 1.0]), yaw_rotation(np.pi))  # facing away: nothing there
    assert not empty.has_point(64, 64)
    with pytest.raises(ValueError, match="no valid depth"):
        camera.pixel_to_world(empty, 64, 64)


def test_lidar_measures_distance_to_walls(world):
    add_box(world.client, [3.0, 0.0, 0.5], [0.1, 5.0, 1.0])  # wall 2.9 m ahead
    lidar = Lidar(world.client)
    ranges = lidar.scan(np.array([0.0, 0.0, 0.3]), 0.0)
    assert ranges.shape == (220,)
    centre = ranges[np.argmin(np.abs(lidar.angles))]
    assert centre == pytest.approx(2.9, abs=0.01)
    sideways = ranges[np.argmin(np.abs(lidar.angles - np.pi / 2))]
    assert sideways == pytest.approx(25.0)  # nothing to the left
    rotated = lidar.scan(np.array([0.0, 0.0, 0.3]), np.pi)  # facing away
    assert rotated[np.argmin(np.abs(lidar.angles))] == pytest.approx(25.0)


def test_a_pose_where_the_renderer_returns_nan_is_rendered_from_1_mm_away(world, monkeypatch):
    add_box(world.client, [2.0, 0.0, 1.0], [0.5, 3.0, 3.0])
    camera = Camera(world.client)
    real_render = camera._render
    calls = []

    def first_call_fails(eye, rotation):
        calls.append(eye)
        rgba, z = real_render(eye, rotation)
        return (rgba * 0, z * np.nan) if len(calls) == 1 else (rgba, z)

    monkeypatch.setattr(camera, "_render", first_call_fails)
    frame = camera.capture(np.array([0.0, 0.0, 1.0]), np.eye(3))
    assert len(calls) == 2 and np.linalg.norm(calls[1] - calls[0]) == pytest.approx(1e-3)
    assert np.isfinite(frame.depth).all() and frame.depth[32, 32] == pytest.approx(1.5, abs=0.02)


def test_pixels_that_stay_nan_at_every_shift_read_as_no_return(world, monkeypatch):
    add_box(world.client, [2.0, 0.0, 1.0], [0.5, 3.0, 3.0])
    camera = Camera(world.client)
    real_render = camera._render

    def corner_always_nan(eye, rotation):
        rgba, z = real_render(eye, rotation)
        z = z.copy()
        z[:10] = np.nan
        return rgba, z

    monkeypatch.setattr(camera, "_render", corner_always_nan)
    frame = camera.capture(np.array([0.0, 0.0, 1.0]), np.eye(3))
    assert np.isfinite(frame.depth).all()
    assert (frame.depth.ravel()[:10] == 0.0).all() and frame.depth[32, 32] == pytest.approx(1.5, abs=0.02)


def test_an_all_nan_image_at_every_shift_is_a_counted_blind_frame(world, monkeypatch):
    camera = Camera(world.client)
    eyes = []

    def always_nan(eye, rotation):
        eyes.append(eye)
        return np.full((128, 128, 4), 255, np.uint8), np.full(128 * 128, np.nan, np.float32)

    monkeypatch.setattr(camera, "_render", always_nan)
    frame = camera.capture(np.array([0.0, 0.0, 1.0]), np.eye(3))
    assert len({tuple(eye) for eye in eyes}) == len(eyes) >= 5  # every attempt from another eye
    assert (frame.depth == 0.0).all() and (frame.rgb == 0).all() and frame.depth.dtype == np.float32
    assert camera.blind_frames == 1
