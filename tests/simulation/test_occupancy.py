import numpy as np
import pytest

from relmogen.simulation.occupancy import FREE, OCCUPIED, UNKNOWN, build_local_map


def scan_of_wall_ahead(distance, num=220, fov=np.deg2rad(220)):
    angles = np.linspace(-fov / 2, fov / 2, num)
    with np.errstate(divide="ignore"):
        ranges = np.where(np.cos(angles) > 1e-6, distance / np.cos(angles), 25.0)
    return np.minimum(ranges, 25.0), angles


def test_wall_ahead_is_occupied_space_before_it_free_behind_robot_unknown():
    ranges, angles = scan_of_wall_ahead(1.5)
    m = build_local_map(ranges, angles, (0.0, 0.0), 25.0, (0.0, 0.0, 0.0), 0.28)
    assert m.grid.shape == (100, 100) and m.grid.dtype == np.uint8
    at = lambda x, y: m.grid[tuple(m.point_to_cell(np.array([x, y])))]
    assert at(1.5 + 0.01, 0.0) == OCCUPIED
    assert at(1.0, 0.0) == FREE
    assert at(2.2, 0.0) == UNKNOWN  # behind the wall
    assert at(-2.0, 0.0) == UNKNOWN  # outside the 220 deg field of view
    assert at(0.0, 0.0) == FREE and at(-0.2, 0.0) == FREE  # the robot's own disc


def test_empty_room_is_free_not_unknown():
    angles = np.linspace(-np.deg2rad(110), np.deg2rad(110), 220)
    m = build_local_map(np.full(220, 25.0), angles, (0.0, 0.0), 25.0, (1.0, 2.0, 0.5), 0.28)
    ahead = m.grid[m.size // 2 :, :]
    assert (ahead == FREE).mean() > 0.9
    assert not (m.grid == OCCUPIED).any()


def test_cell_and_world_conversions_round_trip():
    angles = np.linspace(-1, 1, 10)
    m = build_local_map(np.full(10, 25.0), angles, (0.2, 0.0), 25.0, (3.0, -1.0, np.pi / 3), 0.28, resolution=0.1)
    assert m.size == 50
    pts = np.array([[0.3, -1.2], [2.0, 2.0]])
    assert np.allclose(m.world_to_robot(m.robot_to_world(pts)), pts)
    cells = m.point_to_cell(pts)
    assert np.allclose(m.cell_to_point(cells), pts, atol=0.05 + 1e-9)
    assert m.contains(np.array([2.6, 0.0])) == False  # noqa: E712


def marched_map(ranges, angles, lidar_xy, max_range, radius, size_m, resolution):
    """The map as a direct ray march: every half cell along each ray up to its range is free,
    its end (if the ray hit something) occupied, the footprint free."""
    n = int(round(size_m / resolution))
    grid = np.full((n, n), UNKNOWN, dtype=np.uint8)
    half = 0.5 * n * resolution

    def mark(points, value):
        cells = np.floor((np.asarray(points).reshape(-1, 2) + half) / resolution).astype(int)
        cells = cells[np.all((cells >= 0) & (cells < n), axis=1)]
        grid[cells[:, 0], cells[:, 1]] = value

    reach = min(max_range, half * np.sqrt(2.0) + np.hypot(*lidar_xy))
    for distance, angle in zip(np.minimum(ranges, max_range), angles):
        direction = np.array([np.cos(angle), np.sin(angle)])
        steps = np.arange(0.0, reach, 0.5 * resolution)
        mark(np.asarray(lidar_xy) + steps[steps < distance, None] * direction, FREE)
    for distance, angle in zip(ranges, angles):
        if distance < max_range:
            mark(np.asarray(lidar_xy) + distance * np.array([np.cos(angle), np.sin(angle)]), OCCUPIED)
    centres = (np.arange(n) + 0.5) * resolution - half
    grid[centres[:, None] ** 2 + centres[None, :] ** 2 <= radius**2] = FREE
    return grid


@pytest.mark.parametrize("resolution, lidar_xy", [(0.05, (0.2, 0.0)), (5.0 / 64, (0.12, -0.03))])
def test_the_cached_ray_cells_give_the_map_of_a_direct_ray_march(resolution, lidar_xy):
    rng = np.random.default_rng(0)
    angles = np.linspace(-2.0, 2.0, 220)
    for _ in range(3):  # the second and third scans reuse the first one's ray cells
        ranges = rng.uniform(0.1, 8.0, angles.size)
        ranges[rng.random(angles.size) < 0.2] = 6.0  # no hit: the whole ray is free
        built = build_local_map(ranges, angles, lidar_xy, 6.0, (1.0, 2.0, 0.3), 0.3, 5.0, resolution)
        assert np.array_equal(built.grid, marched_map(ranges, angles, lidar_xy, 6.0, 0.3, 5.0, resolution))
