"""The Fetch URDF: loads, has every name the spec uses, primitive geometry only."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pybullet as p


def _spec_names(spec):
    joints = [*spec.controlled_joints, *vars(spec.head_joints).values(), *spec.gripper_joints]
    links = [spec.end_effector_link, spec.camera_link, spec.lidar_link, *spec.gripper_links,
             *spec.wheel_links, *spec.caster_links]
    return joints, links


def test_urdf_has_only_primitive_geometry(fetch_spec):
    root = ET.parse(fetch_spec.urdf_path).getroot()
    geometries = [g for g in root.iter("geometry")]
    assert geometries
    assert not list(root.iter("mesh"))
    assert all(len(g) == 1 and g[0].tag in {"box", "cylinder", "sphere"} for g in geometries)
    assert len(root.findall("link")) <= 25


def test_urdf_loads_with_all_named_joints_and_links(client, fetch_spec):
    body = p.loadURDF(str(fetch_spec.urdf_path), physicsClientId=client)
    count = p.getNumJoints(body, physicsClientId=client)
    infos = [p.getJointInfo(body, j, physicsClientId=client) for j in range(count)]
    joint_names = {i[1].decode() for i in infos}
    link_names = {i[12].decode() for i in infos} | {p.getBodyInfo(body, physicsClientId=client)[0].decode()}
    joints, links = _spec_names(fetch_spec)
    assert set(joints) <= joint_names
    assert set(links) <= link_names
    assert {"head_camera_joint", "gripper_axis", "laser_joint", "torso_lift_joint"} <= joint_names


def test_joint_limits_match_public_values(robot):
    lift = robot.joint_indices["torso_lift_joint"]
    assert (robot.joint_lower[lift], robot.joint_upper[lift]) == (0.0, 0.38615)
    pan = robot.joint_indices["shoulder_pan_joint"]
    assert (robot.joint_lower[pan], robot.joint_upper[pan]) == (-1.6056, 1.6056)
    roll = robot.joint_indices["wrist_roll_joint"]
    assert robot.joint_lower[roll] <= -3.14159 and robot.joint_upper[roll] >= 3.14159
