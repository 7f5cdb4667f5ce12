"""The arm's collision check in C++, for the inside of an IK solve or a plan: Pinocchio's forward
kinematics and Coal's (FCL's successor) broadphase and narrowphase, one call per query.

``ArmCollisionChecker``'s PyBullet check sets the joints, runs the whole world's broadphase and
then a self-collision copy's (about 50-90 us). Inside ``ArmCollisionChecker.other_joints_held()``
the base and the robot's other joints stay put, so ``CoalArmCollision.hold`` builds, once per
IK solve or plan, the robot's collision geometry (from its URDF) with the world's boxes that the
arm can reach (``relmogen.simulation.shapes``), placed in the robot's base frame, and the pairs
the PyBullet check tests:

* every link moved by the planning joints against every world box, touching allowed to
  ``-threshold`` metres deep (the gripper's penetration allowances, as a negative security margin),
  except link pairs whose contacts are off (``shapes.ignore_contacts``: the cabinets and the
  gripper fingers), which PyBullet's contact query leaves out too;
* the checker's self-collision pairs.

A query then sets only the planning joints. The answers differ from PyBullet's only near contact:
PyBullet turns URDF cylinders into convex hulls, Coal keeps them exact.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin
import pybullet as p

from relmogen.robots.robot import BASE_LINK, Robot
from relmogen.simulation.shapes import base_inertial_position, body_boxes, changes, contacts_ignored

import coal  # noqa: E402  (after pinocchio, which loads the same Coal library)

SELF_MARGIN_M = 0.0  # self pairs closer than this touch; 0 agrees best with PyBullet (0.005-0.01 m: 91-96% equal)
REACH_MARGIN_M = 0.3  # world boxes farther than the arm's reach plus this from its base are left out


class UnknownCollisionGeometry(RuntimeError):
    """A body in the arm's reach whose collision boxes were not recorded (``relmogen.simulation.shapes``)."""


class CoalArmCollision:
    """``hold(...)`` then ``collides(q)`` for the planning joints ``q``; see the module doc."""

    def __init__(self, client: int, robot: Robot, planning_joints: Sequence[int],
                 self_pairs: Sequence[tuple[int, int]] = ()):
        self.client, self.robot = client, robot
        urdf = str(Path(robot.spec.urdf_path))
        self.model = pin.buildModelFromUrdf(urdf)
        self.robot_geometry = pin.buildGeomFromUrdf(self.model, urdf, pin.GeometryType.COLLISION)
        self.data = self.model.createData()
        self._joint_slots = self._pybullet_joint_slots()
        self._planning_slots = np.array([self._single_slot(int(j)) for j in planning_joints])
        self._link_geometries = self._geometries_per_link()
        for a, b in self_pairs:  # touching counts: security margin 0, every hold
            for index_a in self.geometries_of(a):
                for index_b in self.geometries_of(b):
                    self.robot_geometry.addCollisionPair(pin.CollisionPair(min(index_a, index_b), max(index_a, index_b)))
        self._reach = float(robot.spec.arm_reach) + REACH_MARGIN_M
        self._geometry = self._geometry_data = self._manager = None
        self._held_world: tuple | None = None  # (world signature, target body) of the geometry built last
        self._q = pin.neutral(self.model)

    # ------------------------------------------------------------------ robot model

    def _pybullet_joint_slots(self) -> dict[int, tuple[int, int]]:
        """PyBullet joint index -> (first configuration slot, slot count) in Pinocchio's ``q``."""
        slots = {}
        for joint_id in range(1, self.model.njoints):
            name = self.model.names[joint_id]
            joint = self.model.joints[joint_id]
            slots[self.robot.joint_indices[name]] = (joint.idx_q, joint.nq)
        return slots

    def _single_slot(self, pybullet_joint: int) -> int:
        slot, count = self._joint_slots[pybullet_joint]
        if count != 1:
            raise ValueError(f"planning joint {pybullet_joint} has {count} configuration values; only "
                             "prismatic and revolute joints can be planned")
        return slot

    def _geometries_per_link(self) -> dict[int, list[int]]:
        """PyBullet link index -> indices of the robot's geometry objects on that link."""
        per_link: dict[int, list[int]] = {}
        for index, geometry in enumerate(self.robot_geometry.geometryObjects):
            per_link.setdefault(self.robot.link_index(self.model.frames[geometry.parentFrame].name), []).append(index)
        return per_link

    def geometries_of(self, link: int) -> list[int]:
        return self._link_geometries.get(link, [])

    # ------------------------------------------------------------------ a hold

    def hold(self, world_thresholds: Mapping[int, float], gripper_links: frozenset[int] | set[int] = frozenset(),
             target_body: int | None = None, target_threshold: float = 0.0) -> None:
        """Geometry for queries while the base and the non-planning joints stay as they are now:
        ``world_thresholds`` gives each moving link's contact distance to the world below which
        it collides (negative: it may sink that deep); ``target_threshold`` replaces it for
        ``gripper_links`` against ``target_body``. The geometry of the previous hold is kept when
        nothing has moved since (an IK solve and the plan after it)."""
        self._q = self._current_configuration()
        held = (self._world_signature(), target_body)
        if held == self._held_world and self._manager is not None:
            return
        geometry = self.robot_geometry.clone()
        margins = [SELF_MARGIN_M] * len(geometry.collisionPairs)  # the self pairs
        world = self._add_world_boxes(geometry)
        robot = self.robot.robot_id
        for link, link_threshold in world_thresholds.items():
            for robot_index in self.geometries_of(link):
                for world_index, body, body_link in world:
                    if contacts_ignored(self.client, robot, link, body, body_link):
                        continue
                    geometry.addCollisionPair(pin.CollisionPair(robot_index, world_index))
                    margins.append(target_threshold if body == target_body and link in gripper_links
                                   else link_threshold)
        self._geometry, self._geometry_data = geometry, pin.GeometryData(geometry)
        for request, margin in zip(self._geometry_data.collisionRequests, margins):
            request.security_margin = margin  # Coal: in collision below this distance
        self._manager = pin.BroadPhaseManager_DynamicAABBTreeCollisionManager(self.model, geometry,
                                                                            self._geometry_data)
        self._held_world = held

    def _world_signature(self) -> tuple:
        """Every other body's base pose, bounding box and joint positions, the robot's base pose, and
        the count of recorded bodies and ignored pairs."""
        client = self.client
        signature = [changes(client), tuple(np.concatenate(self.robot.link_pose(BASE_LINK)).tolist())]
        for body in self._other_bodies():
            signature.append(p.getBasePositionAndOrientation(body, physicsClientId=client))
            signature.append(p.getAABB(body, physicsClientId=client))  # a removed body's id may come back as another
            joints = p.getNumJoints(body, physicsClientId=client)
            if joints:
                signature.append(tuple(state[0] for state in p.getJointStates(body, range(joints), physicsClientId=client)))
        return tuple(signature)

    def _current_configuration(self) -> np.ndarray:
        q = pin.neutral(self.model)
        joints = sorted(self._joint_slots)
        states = p.getJointStates(self.robot.robot_id, joints, physicsClientId=self.client)
        for joint, state in zip(joints, states):
            slot, count = self._joint_slots[joint]
            q[slot:slot + count] = [np.cos(state[0]), np.sin(state[0])] if count == 2 else [state[0]]
        return q

    def _add_world_boxes(self, geometry: pin.GeometryModel) -> list[tuple[int, int, int]]:
        """Adds the world's shapes within the arm's reach, in the base frame; returns
        (geometry index, body, link) per shape."""
        to_base = p.invertTransform(*self.robot.link_pose(BASE_LINK))
        arm_base = tuple(self.robot.arm_base_position())
        added = []
        for body in self._other_bodies():
            for number, (link, shape, pose, radius) in enumerate(self._world_shapes(body)):
                if radius is not None and math.dist(pose[0], arm_base) > self._reach + radius:
                    continue
                position, orientation = p.multiplyTransforms(*to_base, *pose)
                placement = pin.SE3(np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3),
                                    np.asarray(position, dtype=np.float64))
                index = geometry.addGeometryObject(pin.GeometryObject(f"world_{body}_{number}", 0, 0, placement, shape))
                added.append((index, body, link))
        return added

    def _world_shapes(self, body: int) -> list[tuple[int, object, tuple, float | None]]:
        """(link, Coal shape, world pose, bounding radius or None if unbounded) of each collision
        shape of ``body``: its recorded boxes, else what PyBullet reports for a URDF body."""
        links = body_boxes(self.client, body)
        if links is None:
            return self._urdf_shapes(body)
        shapes = []
        for link, boxes in links.items():
            frame = self._link_frame(body, link)
            for box in boxes:
                pose = p.multiplyTransforms(*frame, box.position, box.orientation)
                shapes.append((link, coal.Box(*(2.0 * np.asarray(box.half_extents))), pose,
                               math.hypot(*box.half_extents)))
        return shapes

    def _urdf_shapes(self, body: int) -> list[tuple[int, object, tuple, float | None]]:
        """A URDF body's boxes, spheres, capsules and planes (PyBullet gives their frames relative
        to each link's centre of mass); a mesh, or a body PyBullet cannot describe, is an error."""
        client, shapes = self.client, []
        for link in range(BASE_LINK, p.getNumJoints(body, physicsClientId=client)):
            try:
                described = p.getCollisionShapeData(body, link, physicsClientId=client)
            except p.error:
                raise UnknownCollisionGeometry(
                    f"body {body} collides but its shapes are unknown: make its boxes with "
                    "relmogen.simulation.shapes.box_collision_shape and record_body") from None
            com = (p.getBasePositionAndOrientation(body, physicsClientId=client) if link == BASE_LINK
                   else p.getLinkState(body, link, physicsClientId=client)[:2])
            for shape in described:
                kind, dimensions, position, orientation = shape[2], shape[3], shape[5], shape[6]
                coal_shape, radius = _coal_shape(body, kind, dimensions)
                shapes.append((link, coal_shape, p.multiplyTransforms(*com, position, orientation), radius))
        return shapes

    def _other_bodies(self) -> list[int]:
        count = p.getNumBodies(physicsClientId=self.client)
        bodies = [p.getBodyUniqueId(i, physicsClientId=self.client) for i in range(count)]
        return [body for body in bodies if body != self.robot.robot_id]

    def _link_frame(self, body: int, link: int):
        """World pose of a recorded body's link frame (the base's: its centre of mass frame times
        the inverse inertial offset)."""
        if link == BASE_LINK:
            com = p.getBasePositionAndOrientation(body, physicsClientId=self.client)
            inertial_position = base_inertial_position(self.client, body)
            return p.multiplyTransforms(*com, *p.invertTransform(inertial_position, (0.0, 0.0, 0.0, 1.0)))
        state = p.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=self.client)
        return state[4], state[5]

    # ------------------------------------------------------------------ queries

    def collides(self, q: Sequence[float]) -> bool:
        """Whether the planning joints at ``q`` put any held pair in contact (``hold`` first)."""
        if self._manager is None:
            raise RuntimeError("CoalArmCollision.collides needs hold() first")
        self._q[self._planning_slots] = q
        return bool(pin.computeCollisions(self.model, self.data, self._manager, self._q, True))



def _coal_shape(body: int, kind: int, dimensions) -> tuple[object, float | None]:
    """A Coal shape for a PyBullet geometry type, and its bounding radius (None: a plane)."""
    if kind == p.GEOM_BOX:
        return coal.Box(*dimensions), 0.5 * math.hypot(*dimensions)
    if kind == p.GEOM_SPHERE:
        return coal.Sphere(dimensions[0]), dimensions[0]
    if kind == p.GEOM_CAPSULE:  # dimensions: length, radius
        return coal.Capsule(dimensions[1], dimensions[0]), 0.5 * dimensions[0] + dimensions[1]
    if kind == p.GEOM_PLANE:
        return coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0), None
    raise UnknownCollisionGeometry(f"body {body}: PyBullet geometry type {kind} (a mesh, or a URDF cylinder, which "
                                   "PyBullet turns into a mesh) has no Coal counterpart here; use boxes")
