"""The measured reachability map: frames, storage, and agreement with the arm's IK."""

from __future__ import annotations

import numpy as np
import pytest

from relmogen.motion_generation.ik import ArmIK
from relmogen.motion_generation.reachability import gripper_positions, measure_reachability
from relmogen.robots.reachability import ReachabilityMap, load_reachability, map_path, world_to_base
from relmogen.robots.robot import Robot
from relmogen.robots.spec import available_robots, load_spec


def test_world_to_base_rotates_into_the_heading():
    base = np.array([1.0, 2.0, np.pi / 2])  # facing +y
    ahead_and_left = np.array([[1.0, 2.5, 0.7], [0.7, 2.0, 0.1]])
    np.testing.assert_allclose(world_to_base(ahead_and_left, base), [[0.5, 0.0, 0.7], [0.0, 0.3, 0.1]], atol=1e-12)


def test_map_lookup_saves_and_loads(tmp_path):
    reachable = np.zeros((4, 4, 4), dtype=bool)
    reachable[1, 2, 3] = True
    reach = ReachabilityMap(np.array([-0.1, -0.1, 0.0]), 0.1, reachable)
    reach.save(tmp_path / "map.npz", samples=1)
    loaded = ReachabilityMap.load(tmp_path / "map.npz")
    points = np.array([[0.05, 0.15, 0.35], [0.05, 0.15, 0.25], [np.nan, 0.0, 0.0], [5.0, 0.15, 0.35], [-0.3, 0.15, 0.35]])
    assert loaded.contains(points).tolist() == [True, False, False, False, False]
    np.testing.assert_array_equal(loaded.reachable, reachable)


def test_measured_map_holds_every_sampled_position_and_its_tolerance():
    spec = load_spec("fetch")
    reach = measure_reachability(spec, samples=300, seed=1, tolerance=0.05)
    positions = gripper_positions(spec, 300, seed=1)
    assert reach.contains(positions).all()
    assert reach.contains(positions + [0.0, 0.0, 0.04]).mean() > 0.95  # within the IK tolerance
    assert not reach.contains(positions + [0.0, 0.0, 0.5]).all()


def test_missing_map_names_the_command(monkeypatch, tmp_path):
    spec = load_spec("fetch")
    monkeypatch.setattr("relmogen.robots.reachability.map_path", lambda _: tmp_path / "none.npz")
    with pytest.raises(FileNotFoundError, match="python -m relmogen.motion_generation.reachability fetch"):
        load_reachability(spec)


@pytest.mark.parametrize("robot", available_robots())
def test_shipped_map_agrees_with_ik(client, robot):
    """Points the map holds are solved by the arm's IK (collisions aside); points it leaves out,
    at 0.6-1.4 m where the sphere mask still allows many, are not."""
    spec = load_spec(robot)
    assert map_path(spec).is_file()
    reach, body = load_reachability(spec), Robot(client, spec)
    ik, rng = ArmIK(client, body), np.random.default_rng(0)
    inside, outside = [], []
    while len(inside) < 12 or len(outside) < 12:
        point = np.array([rng.uniform(0.6, 1.4), rng.uniform(-0.6, 0.6), rng.uniform(0.2, 1.4)])
        group = inside if reach.contains(point) else outside
        if len(group) < 12:
            group.append(ik.solve(point, rng, 100, 50, 0.05).config is not None)
    assert np.mean(inside) >= 0.9 and np.mean(outside) <= 0.1
