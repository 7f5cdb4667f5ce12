"""The Movo-like robot: its spec loads, its kinematics are Movo's (larger base, longer arm, its
own camera height) and every task x control works with it (Gymnasium's checker)."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from relmogen.envs.control_registry import CONTROL_NAMES
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.motion_generation.arm import ArmCollisionChecker
from relmogen.robots.robot import Robot
from relmogen.robots.spec import available_robots, load_spec
from relmogen.tasks import TASKS


@pytest.fixture
def movo_spec():
    return load_spec("movo")


@pytest.fixture
def movo(client, floor, movo_spec):
    return Robot(client, movo_spec)


def _header_number(spec, label: str) -> float:
    """A number stated in the URDF header, e.g. 'camera height at the default pose (...): 0.9968 m'."""
    header = spec.urdf_path.read_text().split("-->", 1)[0]
    match = re.search(label + r"[^:]*:\s*([0-9.]+) m", header)
    assert match, f"{label!r} not in the header of {spec.urdf_path.name}"
    return float(match.group(1))


def _farthest_reach(robot: Robot, samples: int = 2000) -> float:
    """Largest end-effector distance from the first arm joint's frame over the zero pose and random
    joint configurations within the limits."""
    rng = np.random.default_rng(0)
    lower, upper = robot.joint_lower[robot.arm_joint_indices], robot.joint_upper[robot.arm_joint_indices]
    best = 0.0
    for q in [np.zeros(8), *rng.uniform(lower, upper, (samples, 8))]:
        robot.set_joint_positions(robot.arm_joint_indices, q)
        best = max(best, float(np.linalg.norm(robot.end_effector_position() - robot.arm_base_position())))
    return best


def test_movo_spec_loads_with_the_controls_layout(movo_spec, fetch_spec):
    assert "movo" in available_robots()
    assert movo_spec.name == "movo" and movo_spec.urdf_path.is_file()
    assert len(movo_spec.arm_joints) == 7 == len(fetch_spec.arm_joints)
    assert len(movo_spec.velocity_limits) == 3 + 7  # wheels, torso, arm
    assert len(movo_spec.controlled_joints) == len(fetch_spec.controlled_joints) == 10
    assert movo_spec.torso_joint == "linear_joint"


def test_movo_urdf_is_primitive_and_has_every_named_part(movo, movo_spec):
    root = ET.parse(movo_spec.urdf_path).getroot()
    assert not list(root.iter("mesh"))
    assert all(len(g) == 1 and g[0].tag in {"box", "cylinder", "sphere"} for g in root.iter("geometry"))
    links = [movo_spec.end_effector_link, movo_spec.camera_link, movo_spec.lidar_link, *movo_spec.gripper_links,
             *movo_spec.wheel_links, *movo_spec.caster_links]
    assert all(movo.link_index(name) is not None for name in links)  # raises on a missing link
    kinds = {j.get("name"): j.get("type") for j in root.iter("joint")}
    assert kinds["linear_joint"] == "prismatic"
    assert kinds[movo_spec.wheel_joints.left] == kinds[movo_spec.wheel_joints.right] == "continuous"


def test_base_is_larger_than_fetchs(movo_spec, fetch_spec):
    assert movo_spec.base_radius > fetch_spec.base_radius == 0.279
    radii = [float(c.get("radius")) for c in ET.parse(movo_spec.urdf_path).getroot()
             .find("link[@name='base_link']").iter("cylinder")]
    assert max(radii) == pytest.approx(movo_spec.base_radius)


def test_arm_reaches_farther_than_fetchs(client, floor, movo, fetch_spec, movo_spec):
    fetch = Robot(client, fetch_spec, base_pose=(0.0, 4.0, 0.0))
    fetch_reach, movo_reach = _farthest_reach(fetch), _farthest_reach(movo)
    assert movo_reach > fetch_reach + 0.05
    assert movo_reach == pytest.approx(_header_number(movo_spec, "fully\\s+stretched"), abs=2e-3)
    assert movo_spec.arm_reach > fetch_spec.arm_reach == 1.2


def test_camera_height_at_the_default_pose_is_the_stated_one(movo, movo_spec, fetch_spec):
    movo.reset((1.0, -1.0, 0.4))
    height = movo.camera_pose()[0][2]
    assert height == pytest.approx(_header_number(movo_spec, "camera height at the default pose"), abs=1e-3)
    assert abs(height - 1.077) > 0.05  # Fetch's (fetch.urdf at its default pose)


def test_tucked_arm_touches_nothing_and_stays_behind_the_camera(client, movo, movo_spec):
    checker = ArmCollisionChecker(client, movo, 0.03)
    assert not checker.ignored_pairs  # no robot link pair is in contact in the tucked pose
    camera_x = movo.camera_pose()[0][0]
    arm_links = [movo.link_index(name) for name in movo_spec.gripper_links]
    assert all(movo.link_pose(link)[0][0] < camera_x for link in arm_links)


@pytest.mark.parametrize("control", CONTROL_NAMES)
@pytest.mark.parametrize("task", sorted(TASKS))
def test_check_env_passes_with_movo(task, control):
    env = RelmogenEnv(task=task, control=control, robot="movo", image_size=32)
    check_env(env, skip_render_check=True)
    env.close()
