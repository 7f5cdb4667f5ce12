"""Developer tool: regenerate ``movo.urdf`` (primitive-geometry, Movo-like robot) from the tables below.

Not imported at runtime; the robot is loaded from the generated URDF plus ``spec.yaml``.
Run ``python relmogen/robots/assets/movo/build_movo_urdf.py`` after editing a number here.
The XML writers (links, joints, primitive inertias) are the Fetch builder's, loaded from
``../fetch/build_fetch_urdf.py``; only the tables and the header are Movo's.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

_FETCH_BUILDER = Path(__file__).resolve().parent.parent / "fetch" / "build_fetch_urdf.py"
_spec = importlib.util.spec_from_file_location("build_fetch_urdf", _FETCH_BUILDER)
_fetch = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_fetch)
link_xml, joint_xml, MATERIALS = _fetch.link_xml, _fetch.joint_xml, _fetch.MATERIALS
WHITE, GREY, DARK, BLACK = _fetch.WHITE, _fetch.GREY, _fetch.DARK, _fetch.BLACK

PI = math.pi

# --------------------------------------------------------------------------- public numbers
WHEEL_R = 0.0762  # movo_base.urdf.xacro wheel_radius (6 in mecanum wheels)
CHASSIS_Z = WHEEL_R  # base_chassis_joint: the chassis frame sits one wheel radius above the floor
TORSO_XYZ = (0.0771402, 0.0, CHASSIS_Z + 0.3938763)  # linear_joint origin (from the chassis)
TORSO_LIMITS = (0.0, 0.472, 1000.0, 0.2)  # linear_joint lower, upper, effort, velocity
LASER_XYZ = (0.3375, 0.0, CHASSIS_Z + 0.1439106)  # front SICK TiM mount (movo_base.urdf.xacro)
PAN_BASE_XYZ = (0.19735, 0.0, 0.3449888)  # movo.urdf.xacro: pan-tilt on linear_actuator_link
PAN_Z, TILT_Z = 0.05525, 0.09075  # movo_pan_tilt.urdf.xacro pan_joint / tilt_joint heights
HEAD_LIMITS = (-PI / 2, PI / 2, 7.0, 0.907571211)
CAMERA_XYZ = (0.05825, 0.0, 0.026)  # Kinect frame ahead of / above the tilt axis (offsets of its mount)
MOVO_ARM_MOUNT = (0.0261046, -0.13335, 0.2799937)  # right JACO2 mount on linear_actuator_link (movo.urdf.xacro)
# JACO2 7-DoF (spherical wrist) joint-to-joint distances, jaco_7dof.urdf.xacro in movo_description:
# base plate -> J1 0.0625, J1 -> J2 0.11875, J2 -> J3 0.205, J3 -> J4 0.205, J4 -> J5 0.2073,
# J5 -> J6 0.10375, J6 -> J7 0.10375, J7 -> ee_link 0.16.
J1_TO_J2 = 0.0625 + 0.11875  # the J1 frame is put on the base plate (on its axis: same geometry)
# Our upright mount: at Movo's mount point, lowered by J1_TO_J2 so that J2 (the shoulder) is where
# Movo's is (its JACO2 base points forward from the mount, J2 at the mount's height)
ARM_MOUNT_XYZ = (MOVO_ARM_MOUNT[0], MOVO_ARM_MOUNT[1], MOVO_ARM_MOUNT[2] - J1_TO_J2)
ARM_SEGMENTS = (0.205, 0.205, 0.2073, 0.10375, 0.10375)  # J2..J7
EE_OFFSET = 0.16
BIG, SMALL = (30.5, 0.691150384), (6.8, 0.921533845)  # (effort N m, velocity rad/s): KA-75+ / KA-58 actuators
ARM_LIMITS = (  # (lower, upper), jaco_7dof.urdf.xacro
    (-PI, PI), (-2.238, 2.238), (-PI, PI), (-2.809, 2.809), (-PI, PI), (-2.78, 2.78), (-PI, PI))
ARM_JOINTS = ("right_shoulder_pan_joint", "right_shoulder_lift_joint", "right_arm_half_joint", "right_elbow_joint",
              "right_wrist_spherical_1_joint", "right_wrist_spherical_2_joint", "right_wrist_3_joint")
ARM_LINKS = ("right_shoulder_link", "right_arm_half_1_link", "right_arm_half_2_link", "right_forearm_link",
             "right_wrist_spherical_1_link", "right_wrist_spherical_2_link", "right_wrist_3_link")
ARM_AXES = ((0, 0, 1), (0, 1, 0), (0, 0, 1), (0, 1, 0), (0, 0, 1), (0, 1, 0), (0, 0, 1))  # roll / flex / ...
# link masses: jaco_7dof.urdf.xacro (the shoulder link carries the base's 0.6496 kg too)
ARM_MASSES = (0.649618 + 0.824524, 0.8447, 0.8447, 0.674254, 0.463, 0.463, 0.190782)
ARM_RADII = (0.045, 0.045, 0.045, 0.04, 0.035, 0.035, 0.035)

# --------------------------------------------------------------------------- our choices
BASE_R = 0.34  # footprint disc through the front/rear laser mounts (+-0.3375 m)
WHEEL_Y, WHEEL_W = 0.23, 0.06
CASTER_R, CASTER_X = 0.04, 0.26
LASER_GAP = (0.19, 0.25)  # no base collision between these heights: the scan plane is free
FINGER_OPEN = 0.04


def arm_tables():
    """Links and joints of the arm: straight up at zero (links along +z), flex joints about y
    (positive tips the next link toward +x), roll joints about the link axis."""
    lengths = (J1_TO_J2, *ARM_SEGMENTS, 0.04)
    links, joints = [], []
    parent, origin = "linear_actuator_link", ARM_MOUNT_XYZ
    for k, (joint, link) in enumerate(zip(ARM_JOINTS, ARM_LINKS)):
        length = lengths[k]
        colour = WHITE if k % 2 == 0 else DARK
        links.append((link, ARM_MASSES[k], [("cyl", ARM_RADII[k], length, "z", (0, 0, length / 2))], colour, True))
        effort, velocity = BIG if k < 4 else SMALL
        joints.append((joint, "revolute", parent, link, origin, ARM_AXES[k], (*ARM_LIMITS[k], effort, velocity)))
        parent, origin = link, (0, 0, length if k < 6 else 0.0)
    # wrist_3 -> ee: the KG2 gripper's palm behind the end-effector frame, fingers at it
    links += [
        ("right_ee_link", 0.55, [("box", (0.08, 0.1, 0.09), (0, 0, -0.075))], GREY, True),
        ("right_gripper_finger1_link", 0.0218, [("box", (0.03, 0.012, 0.06), (0, 0.006, -0.015))], DARK, True),
        ("right_gripper_finger2_link", 0.0218, [("box", (0.03, 0.012, 0.06), (0, -0.006, -0.015))], DARK, True),
    ]
    joints += [
        ("right_ee_fixed_joint", "fixed", "right_wrist_3_link", "right_ee_link", (0, 0, EE_OFFSET)),
        ("right_gripper_finger1_joint", "prismatic", "right_ee_link", "right_gripper_finger1_link", (0, 0.012, 0),
         (0, 1, 0), (0.0, FINGER_OPEN, 3.0, 0.05)),
        ("right_gripper_finger2_joint", "prismatic", "right_ee_link", "right_gripper_finger2_link", (0, -0.012, 0),
         (0, -1, 0), (0.0, FINGER_OPEN, 3.0, 0.05)),
    ]
    return links, joints


LOWER = LASER_GAP[0] - 0.04
UPPER = 0.42 - LASER_GAP[1]
# (name, mass, shapes, colour, collide); the first shape carries the inertia
BODY_LINKS = [
    ("base_link", 44.2877 + 7.753378, [("cyl", BASE_R, LOWER, "z", (0, 0, 0.04 + LOWER / 2)),
                                       ("cyl", BASE_R, UPPER, "z", (0, 0, LASER_GAP[1] + UPPER / 2))], GREY, True),
    ("right_wheel_link", 2.0, [("cyl", WHEEL_R, WHEEL_W, "y", (0, 0, 0))], BLACK, True),
    ("left_wheel_link", 2.0, [("cyl", WHEEL_R, WHEEL_W, "y", (0, 0, 0))], BLACK, True),
    ("front_caster_link", 0.1, [("sph", CASTER_R, (0, 0, 0))], BLACK, True),
    ("rear_caster_link", 0.1, [("sph", CASTER_R, (0, 0, 0))], BLACK, True),
    # the fixed column is visual only; the moving column reaches down into it
    ("linear_actuator_fixed_link", 15.877331, [("box", (0.18, 0.16, 0.6), (0.0, 0, 0.6))], GREY, False),
    ("linear_actuator_link", 12.926242 + 6.246912, [("box", (0.2, 0.16, 0.68), (-0.08, 0, 0.13))], WHITE, True),
    ("pan_base_link", 0.271282, [("cyl", 0.04, PAN_Z, "z", (0, 0, PAN_Z / 2))], DARK, True),
    ("pan_link", 0.470548, [("box", (0.06, 0.08, TILT_Z - 0.02), (0, 0, TILT_Z / 2 - 0.01))], DARK, True),
    ("tilt_link", 0.434513, [("box", (0.07, 0.25, 0.07), (0.03, 0, 0.02))], BLACK, True),
    ("movo_camera_link", 0.01, [("box", (0.01, 0.2, 0.02), (-0.005, 0, 0))], BLACK, False),
    ("front_laser_link", 0.01, [("cyl", 0.03, 0.05, "z", (0, 0, 0))], BLACK, False),
]

# (name, type, parent, child, xyz, axis, (lower, upper, effort, velocity))
BODY_JOINTS = [
    ("right_wheel_joint", "continuous", "base_link", "right_wheel_link", (0, -WHEEL_Y, WHEEL_R),
     (0, 1, 0), (None, None, 15.0, 13.1)),
    ("left_wheel_joint", "continuous", "base_link", "left_wheel_link", (0, WHEEL_Y, WHEEL_R),
     (0, 1, 0), (None, None, 15.0, 13.1)),
    ("front_caster_joint", "fixed", "base_link", "front_caster_link", (CASTER_X, 0, CASTER_R)),
    ("rear_caster_joint", "fixed", "base_link", "rear_caster_link", (-CASTER_X, 0, CASTER_R)),
    ("linear_actuator_fixed_joint", "fixed", "base_link", "linear_actuator_fixed_link", (0, 0, CHASSIS_Z)),
    ("linear_joint", "prismatic", "base_link", "linear_actuator_link", TORSO_XYZ, (0, 0, 1), TORSO_LIMITS),
    ("pan_base_joint", "fixed", "linear_actuator_link", "pan_base_link", PAN_BASE_XYZ),
    ("pan_joint", "revolute", "pan_base_link", "pan_link", (0, 0, PAN_Z), (0, 0, 1), HEAD_LIMITS),
    ("tilt_joint", "revolute", "pan_link", "tilt_link", (0, 0, TILT_Z), (0, 1, 0), HEAD_LIMITS),
    ("movo_camera_joint", "fixed", "tilt_link", "movo_camera_link", CAMERA_XYZ),
    ("front_laser_joint", "fixed", "base_link", "front_laser_link", LASER_XYZ),
]

DEFAULT_TORSO = 0.02  # spec.yaml default_torso
HEAD_TILT_NAVIGATION = 0.17  # spec.yaml head_tilt_navigation: the head at reset


def camera_height(torso: float = DEFAULT_TORSO, tilt: float = HEAD_TILT_NAVIGATION) -> float:
    """Height of the camera frame above the floor (head pan anywhere, tilt ``tilt``)."""
    tilt_axis = TORSO_XYZ[2] + torso + PAN_BASE_XYZ[2] + PAN_Z + TILT_Z
    return tilt_axis - math.sin(tilt) * CAMERA_XYZ[0] + math.cos(tilt) * CAMERA_XYZ[2]


def header() -> str:
    reach = J1_TO_J2 + sum(ARM_SEGMENTS) + EE_OFFSET
    return f"""<?xml version="1.0"?>
<!--
  Movo-like mobile manipulator (Kinova MOVO with one 7-DoF JACO2 arm), primitive-geometry model
  written for relmogen (generated by build_movo_urdf.py in this folder; edit that file, not this
  one). The joint names are Movo's (the right arm's, "right_" prefix).

  Sources of the numbers (public Kinova material, github.com/Kinovarobotics/kinova-movo,
  movo_common/movo_description/urdf):
  * movo_base.urdf.xacro: wheel radius 0.0762 m, chassis frame one wheel radius above the floor,
    linear_joint (the torso) origin (0.0771402, 0, 0.3938763) from the chassis, limits 0..0.472 m,
    effort 1000 N, velocity 0.2 m/s; front SICK TiM laser at (0.3375, 0, 0.1439106) from the
    chassis (the rear one is omitted); chassis and column masses.
  * movo.urdf.xacro: pan-tilt base at (0.19735, 0, 0.3449888) and the right JACO2 mount at
    (0.0261046, -0.13335, 0.2799937) on linear_actuator_link.
  * movo_pan_tilt.urdf.xacro: pan and tilt heights 0.05525 / 0.09075 m, limits +-pi/2, effort 7,
    velocity 0.9076 rad/s; the Kinect frame 0.05825 m ahead of the tilt axis.
  * manipulation/jaco/jaco_7dof.urdf.xacro: JACO2 7-DoF (spherical wrist) joint-to-joint distances
    0.0625 (base plate to J1), 0.11875, 0.205, 0.205, 0.2073, 0.10375, 0.10375 and 0.16 (J7 to
    ee_link), joint limits (J2 +-2.238, J4 +-2.809, J6 +-2.78, the rolls +-pi), velocities
    (0.6912 rad/s J1-J4, 0.9215 J5-J7) and link masses. Efforts: the KA-75+ (J1-J4) and KA-58
    (J5-J7) actuators' peak torques, 30.5 and 6.8 N m (that file's efforts, 18000-60000, are not
    physical).
  * Geometry: NOT the Movo meshes. Boxes, cylinders and spheres sized by hand; the base is a disc of
    radius {BASE_R} m through the laser mounts (Fetch: 0.279 m).
  Kinematics (the spec's numbers):
  * arm length from the J1 frame (put on the arm's base plate) to the end-effector frame, fully
    stretched: {reach:.4f} m (Fetch: 1.097 m from shoulder_pan_link to gripper_link);
  * camera height at the default pose (torso {DEFAULT_TORSO} m, head tilted {HEAD_TILT_NAVIGATION} rad down):
    {camera_height():.4f} m (Fetch: 1.077 m); 0.34 m ahead of the base centre (Fetch: 0.17 m).
  Deviations from Movo, on purpose:
  * Movo's base is holonomic (four mecanum wheels, a "Vector" base); here it is a differential
    drive (two wheels at +-{WHEEL_Y} m, two zero-friction casters), the controls' convention;
  * the arm is mounted upright (J1 vertical), straight up at zero, its base plate {J1_TO_J2} m below
    Movo's right-arm mount so that J2 (the shoulder) is at the height of Movo's, which has the JACO2
    base pointing forward from the mount; so the tucked arm stands folded beside the column,
    behind the camera. The J1 frame is on the base plate (base and J1 are coaxial: same shape);
  * the KG2/KG3 fingers are revolute on Movo; here two prismatic fingers (0..{FINGER_OPEN} m);
  * front_laser_link is upright (Movo mounts it upside down) and has no collision shape; the
    base collision body has a gap at the scan plane (z {LASER_GAP[0]}..{LASER_GAP[1]});
  * linear_actuator_fixed_link is visual only; the moving column's box reaches 0.21 m below the
    linear_joint origin; the lower/upper body skins are folded into the base / the moving column;
  * wheel masses (2 kg) and wheel motor efforts (15 N m) are our choice; no joint damping.
-->
<robot name="movo">
"""


def build() -> str:
    arm_links, arm_joints = arm_tables()
    return _fetch.robot_xml(header(), BODY_LINKS + arm_links, BODY_JOINTS + arm_joints)


if __name__ == "__main__":
    out = Path(__file__).with_name("movo.urdf")
    out.write_text(build())
    print(f"wrote {out}")
