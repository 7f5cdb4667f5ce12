"""A kitchen base cabinet built from boxes: a static carcass, a drawer on top, a door below.

One PyBullet multibody per cabinet, created once and re-posed per episode:

* base: the carcass (mass 0, so it never moves), a box standing on the floor;
* link 0: the drawer (prismatic along the outward normal, 0 = closed, + = open, metres);
* link 1: the drawer handle (fixed to the drawer);
* link 2: the door (revolute about a vertical hinge at the carcass's front corner on its
  local -y side, 0 = closed, + = swung out into the room, radians);
* link 3: the door handle (fixed to the door, near its free edge).

Local frame (the body frame): origin at the carcass's front face, centred, on the floor;
+x points out of the front into the room, +z up. Closed fronts are overlay panels lying in
x in [0, FRONT_THICKNESS]. Self-collision is off (PyBullet's default for ``createMultiBody``),
so the drawer tray slides inside the solid carcass box.

Joint physics: limits via ``changeDynamics``, viscous damping, and dry friction as a
zero-velocity motor with a small maximum force, so a still joint stays where it is (nothing
drifts shut) while the arm's push (tens of newtons) moves it easily.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as p

from relmogen.simulation.frames import FacesYaw
from relmogen.simulation.shapes import box_collision_shape, ignore_contacts, record_body

WIDTH, DEPTH, HEIGHT = 0.5, 0.5, 0.85
FRONT_THICKNESS = 0.02
FRONT_GAP = 0.01  # between neighbouring fronts and around the carcass edges
DRAWER_Z = (0.62, 0.82)  # bottom and top of the drawer front
DOOR_Z = (0.10, 0.58)
HANDLE_DEPTH = 0.025

DRAWER_LINK, DRAWER_HANDLE_LINK, DOOR_LINK, DOOR_HANDLE_LINK = 0, 1, 2, 3
DRAWER_LIMITS = (0.0, 0.40)  # metres
DOOR_LIMITS = (0.0, math.radians(100.0))

CARCASS_RGBA = (0.50, 0.32, 0.18, 1.0)  # wood brown
FRONT_RGBA = (0.15, 0.45, 0.75, 1.0)  # blue
HANDLE_RGBA = (0.95, 0.80, 0.10, 1.0)  # yellow


@dataclass(frozen=True)
class JointPhysics:
    mass: float  # kg of the moving part
    friction: float  # N (drawer) or N m (door): the zero-velocity motor's maximum force
    damping: float  # N s/m or N m s/rad


DRAWER_PHYSICS = JointPhysics(mass=2.0, friction=3.0, damping=8.0)
DOOR_PHYSICS = JointPhysics(mass=2.0, friction=0.6, damping=1.0)


def _box(client: int, half_extents, offset, with_collision: bool = True) -> tuple[int, int]:
    visual = p.createVisualShape(p.GEOM_BOX, halfExtents=list(half_extents), visualFramePosition=list(offset),
                                 physicsClientId=client)
    collision = box_collision_shape(client, [half_extents], [offset]) if with_collision else -1
    return collision, visual


def _drawer_shapes(client: int) -> tuple[int, int]:
    """Front panel plus a tray reaching back into the carcass (both in the drawer frame,
    origin at the closed front's back face, centred on the front)."""
    half_w, half_h = 0.5 * WIDTH - FRONT_GAP, 0.5 * (DRAWER_Z[1] - DRAWER_Z[0])
    tray_depth = DEPTH - 0.06
    half = [[0.5 * FRONT_THICKNESS, half_w, half_h], [0.5 * tray_depth, half_w - 0.02, half_h - 0.02]]
    pos = [[0.5 * FRONT_THICKNESS, 0, 0], [-0.5 * tray_depth, 0, -0.01]]
    visual = p.createVisualShapeArray([p.GEOM_BOX] * 2, halfExtents=half, visualFramePositions=pos,
                                      physicsClientId=client)
    return box_collision_shape(client, half, pos), visual


def door_width() -> float:
    return WIDTH - 2 * FRONT_GAP


def _link_specs(client: int) -> list[dict]:
    drawer_zc = 0.5 * sum(DRAWER_Z)
    door_zc = 0.5 * sum(DOOR_Z)
    door_w = door_width()
    door_half_h = 0.5 * (DOOR_Z[1] - DOOR_Z[0])
    handle_x = FRONT_THICKNESS + 0.5 * HANDLE_DEPTH
    return [
        dict(shapes=_drawer_shapes(client), mass=DRAWER_PHYSICS.mass, parent=0, joint=p.JOINT_PRISMATIC,
             position=(0.0, 0.0, drawer_zc), axis=(1, 0, 0)),
        dict(shapes=_box(client, (0.5 * HANDLE_DEPTH, 0.08, 0.012), (0, 0, 0)), mass=0.1, parent=1,
             joint=p.JOINT_FIXED, position=(handle_x, 0.0, 0.0), axis=(0, 0, 0)),
        # Hinge at the back edge of the closed door; axis -z so positive angles swing out (+x).
        dict(shapes=_box(client, (0.5 * FRONT_THICKNESS, 0.5 * door_w, door_half_h),
                         (0.5 * FRONT_THICKNESS, 0.5 * door_w, 0)),
             mass=DOOR_PHYSICS.mass, parent=0, joint=p.JOINT_REVOLUTE,
             position=(0.0, -0.5 * WIDTH + FRONT_GAP, door_zc), axis=(0, 0, -1)),
        dict(shapes=_box(client, (0.5 * HANDLE_DEPTH, 0.012, 0.08), (0, 0, 0)), mass=0.1, parent=3,
             joint=p.JOINT_FIXED, position=(handle_x, door_w - 0.06, 0.12), axis=(0, 0, 0)),
    ]


class Cabinet(FacesYaw):
    """One cabinet set (drawer + door); see the module docstring for frames and links. ``normal``
    points out of the front, into the room; ``along`` runs along the front, from the door hinge
    towards the door's free edge."""

    def __init__(self, client: int):
        self.client = client
        self.body = self._create()
        self._set_joint_physics()
        self.yaw = 0.0
        self.front_xy = np.zeros(2)

    def _create(self) -> int:
        client = self.client
        carcass = _box(client, (0.5 * DEPTH, 0.5 * WIDTH, 0.5 * HEIGHT), (-0.5 * DEPTH, 0, 0.5 * HEIGHT))
        links = _link_specs(client)
        body = p.createMultiBody(
            baseMass=0.0, baseCollisionShapeIndex=carcass[0], baseVisualShapeIndex=carcass[1],
            linkMasses=[spec["mass"] for spec in links],
            linkCollisionShapeIndices=[spec["shapes"][0] for spec in links],
            linkVisualShapeIndices=[spec["shapes"][1] for spec in links],
            linkPositions=[spec["position"] for spec in links],
            linkOrientations=[(0, 0, 0, 1)] * len(links),
            linkInertialFramePositions=[(0, 0, 0)] * len(links),
            linkInertialFrameOrientations=[(0, 0, 0, 1)] * len(links),
            linkParentIndices=[spec["parent"] for spec in links],
            linkJointTypes=[spec["joint"] for spec in links],
            linkJointAxis=[spec["axis"] for spec in links],
            physicsClientId=client,
        )
        record_body(client, body, {-1: carcass[0], **{link: spec["shapes"][0] for link, spec in enumerate(links)}})
        for link, rgba in ((-1, CARCASS_RGBA), (DRAWER_LINK, FRONT_RGBA), (DOOR_LINK, FRONT_RGBA),
                           (DRAWER_HANDLE_LINK, HANDLE_RGBA), (DOOR_HANDLE_LINK, HANDLE_RGBA)):
            p.changeVisualShape(body, link, rgbaColor=list(rgba), physicsClientId=client)
        return body

    def _set_joint_physics(self) -> None:
        for link, limits, physics in ((DRAWER_LINK, DRAWER_LIMITS, DRAWER_PHYSICS),
                                      (DOOR_LINK, DOOR_LIMITS, DOOR_PHYSICS)):
            p.changeDynamics(self.body, link, jointLowerLimit=limits[0], jointUpperLimit=limits[1],
                             jointDamping=physics.damping, linearDamping=0.0, angularDamping=0.0,
                             lateralFriction=0.6, physicsClientId=self.client)
        self._hold_with_friction()

    def _hold_with_friction(self) -> None:
        for link, physics in ((DRAWER_LINK, DRAWER_PHYSICS), (DOOR_LINK, DOOR_PHYSICS)):
            p.setJointMotorControl2(self.body, link, p.VELOCITY_CONTROL, targetVelocity=0.0,
                                    force=physics.friction, physicsClientId=self.client)

    def ignore_collisions_with(self, body: int, links: list[int]) -> None:
        """No contacts between the cabinet and these links of ``body``. Used for the
        robot's gripper fingers: pressed sideways against a front at its stop they are forced
        past their joint limits, after which the tucked arm is in self-collision and no later
        arm subgoal can start; the palm does the pushing instead."""
        for own in (-1, DRAWER_LINK, DRAWER_HANDLE_LINK, DOOR_LINK, DOOR_HANDLE_LINK):
            for link in links:
                ignore_contacts(self.client, self.body, own, body, link)

    # ------------------------------------------------------------------ episode set-up
    def place(self, front_xy, yaw: float) -> None:
        """Put the carcass's front-face centre (floor level) at ``front_xy``, +x along ``yaw``."""
        self.front_xy, self.yaw = np.asarray(front_xy, dtype=np.float64), float(yaw)
        p.resetBasePositionAndOrientation(self.body, [*self.front_xy, 0.0],
                                          p.getQuaternionFromEuler([0, 0, self.yaw]), physicsClientId=self.client)

    def set_openings(self, drawer_m: float, door_rad: float) -> None:
        p.resetJointState(self.body, DRAWER_LINK, float(drawer_m), 0.0, physicsClientId=self.client)
        p.resetJointState(self.body, DOOR_LINK, float(door_rad), 0.0, physicsClientId=self.client)
        self._hold_with_friction()

    # ------------------------------------------------------------------ state
    def drawer_opening(self) -> float:
        return float(p.getJointState(self.body, DRAWER_LINK, physicsClientId=self.client)[0])

    def door_angle(self) -> float:
        return float(p.getJointState(self.body, DOOR_LINK, physicsClientId=self.client)[0])

    # ------------------------------------------------------------------ world geometry
    def to_world(self, x: float, y: float) -> np.ndarray:
        return self.front_xy + x * self.normal + y * self.along

    def hinge_xy(self) -> np.ndarray:
        return self.to_world(0.0, -0.5 * WIDTH + FRONT_GAP)

    def door_face_point(self, radius: float, angle: float | None = None) -> np.ndarray:
        """World xy on the door's outer face, ``radius`` m from the hinge axis, at ``angle``."""
        angle = self.door_angle() if angle is None else angle
        return self.hinge_xy() + radius * self.door_direction(angle) + FRONT_THICKNESS * self.door_outer_normal(angle)

    def door_direction(self, angle: float) -> np.ndarray:
        """Unit vector from the hinge to the free edge with the door at ``angle``."""
        return math.cos(angle) * self.along + math.sin(angle) * self.normal

    def door_outer_normal(self, angle: float) -> np.ndarray:
        """Unit normal of the door's outer face (the room side when closed)."""
        return math.cos(angle) * self.normal - math.sin(angle) * self.along

    def drawer_front_point(self) -> np.ndarray:
        return self.to_world(self.drawer_opening() + FRONT_THICKNESS, 0.0)

    def footprint_corners(self, reach: float) -> np.ndarray:
        """Corners (4, 2) of the carcass plus ``reach`` metres in front of it (opened parts)."""
        half = 0.5 * WIDTH
        local = [(-DEPTH, -half - FRONT_THICKNESS), (reach, -half - FRONT_THICKNESS), (reach, half), (-DEPTH, half)]
        return np.array([self.to_world(x, y) for x, y in local])
