"""One robot loaded in a PyBullet client, driven through names from its ``EmbodimentSpec``.

Every PyBullet call passes ``physicsClientId`` explicitly, so several clients can coexist in one
process. Indices are resolved once in ``__init__``; the per-step methods do no name lookups.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pybullet as p

from relmogen.robots.spec import EmbodimentSpec

BASE_LINK = -1
FAR_ABOVE = 100.0  # m: where a reset puts the robot for one collision pass (clear of every scene)


class Robot:
    """A wheeled mobile manipulator (differential base, torso, arm, head, gripper)."""

    def __init__(self, client: int, spec: EmbodimentSpec, base_pose: Sequence[float] = (0.0, 0.0, 0.0)):
        self.client, self.spec = client, spec
        self.robot_id = p.loadURDF(str(spec.urdf_path), useFixedBase=False,
                                   flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client)
        self._index_joints_and_links()
        self._cache_limits_and_frames()
        self._set_contact_friction()
        self.reset(base_pose)

    # ------------------------------------------------------------------ setup

    def _index_joints_and_links(self) -> None:
        self.joint_indices: dict[str, int] = {}
        root_name = p.getBodyInfo(self.robot_id, physicsClientId=self.client)[0].decode()
        self.link_indices: dict[str, int] = {root_name: BASE_LINK}
        for j in range(p.getNumJoints(self.robot_id, physicsClientId=self.client)):
            info = p.getJointInfo(self.robot_id, j, physicsClientId=self.client)
            self.joint_indices[info[1].decode()] = j
            self.link_indices[info[12].decode()] = j
        spec = self.spec
        self.controlled_joint_indices = self._joints(spec.controlled_joints)
        self.arm_joint_indices = self._joints(spec.planning_joints)
        self.wheel_joint_indices = self.controlled_joint_indices[:2]
        self.head_joint_indices = self._joints((spec.head_joints.pan, spec.head_joints.tilt))
        self.gripper_joint_indices = self._joints(spec.gripper_joints)
        self.end_effector_link_index = self.link_index(spec.end_effector_link)
        self.camera_link_index = self.link_index(spec.camera_link)
        self.lidar_link_index = self.link_index(spec.lidar_link)
        self.gripper_link_indices = tuple(self.link_index(n) for n in spec.gripper_links)
        self.floor_contact_link_indices = tuple(self.link_index(n) for n in (*spec.wheel_links, *spec.caster_links))
        self.link_names = {i: name for name, i in self.link_indices.items()}

    def _joints(self, names: Sequence[str]) -> np.ndarray:
        missing = [n for n in names if n not in self.joint_indices]
        if missing:
            raise ValueError(f"{self.spec.name}: joints {missing} not in {self.spec.urdf_path.name}")
        return np.array([self.joint_indices[n] for n in names], dtype=np.int64)

    def link_index(self, name: str) -> int:
        """PyBullet link index of a link name (the root link is -1)."""
        try:
            return self.link_indices[name]
        except KeyError:
            raise ValueError(f"{self.spec.name}: no link {name!r}; links: {sorted(self.link_indices)}") from None

    def _cache_limits_and_frames(self) -> None:
        infos = [p.getJointInfo(self.robot_id, int(j), physicsClientId=self.client)
                 for j in range(p.getNumJoints(self.robot_id, physicsClientId=self.client))]
        self.joint_lower = np.array([i[8] for i in infos])
        self.joint_upper = np.array([i[9] for i in infos])
        self.joint_max_force = np.array([i[10] for i in infos])
        self.velocity_limits = np.array(self.spec.velocity_limits)
        self._controlled_forces = self.joint_max_force[self.controlled_joint_indices]
        # PyBullet's base pose is the base inertial frame; remember the link-frame -> COM offset.
        dyn = p.getDynamicsInfo(self.robot_id, BASE_LINK, physicsClientId=self.client)
        self._base_com_offset = (dyn[3], dyn[4])
        self._base_height = self._height_that_puts_wheels_on_floor()

    def _height_that_puts_wheels_on_floor(self) -> float:
        self.set_base_pose(0.0, 0.0, 0.0, z=0.0)
        wheel_z = [self.link_pose(int(j))[0][2] for j in self.wheel_joint_indices]
        return self.spec.wheel_radius - float(np.mean(wheel_z))

    def _set_contact_friction(self) -> None:
        for link in (BASE_LINK, *(self.link_index(n) for n in self.spec.caster_links)):
            p.changeDynamics(self.robot_id, link, lateralFriction=0.0, rollingFriction=0.0,
                             spinningFriction=0.0, physicsClientId=self.client)
        for name in self.spec.wheel_links:
            p.changeDynamics(self.robot_id, self.link_index(name), lateralFriction=self.spec.wheel_friction,
                             rollingFriction=0.0, spinningFriction=0.0, physicsClientId=self.client)

    # ------------------------------------------------------------------ reset / base

    def reset(self, base_pose: Sequence[float] = (0.0, 0.0, 0.0), head_tilt: float | None = None) -> None:
        """Teleport to ``(x, y, yaw)`` on the floor in the tucked pose, at rest, holding it.

        The robot first leaves the scene for one collision pass: PyBullet keeps a touching pair's
        contact cache (warm-started impulses) across teleports, so without it the first 0.1 s of
        driving after a reset depended on where the previous episode ended (a seeded episode
        was not reproducible; Gymnasium's determinism check failed for some actions)."""
        self._place_base(*base_pose, z=self._base_height + FAR_ABOVE)
        p.performCollisionDetection(physicsClientId=self.client)
        self.set_base_pose(*base_pose)
        tilt = self.spec.head_tilt_navigation if head_tilt is None else head_tilt
        held = np.concatenate([self.arm_joint_indices, self.head_joint_indices, self.gripper_joint_indices])
        targets = np.concatenate([[self.spec.default_torso], self.spec.default_arm_pose, [0.0, tilt],
                                  self.spec.gripper_open])
        for j, q in zip(np.concatenate([self.wheel_joint_indices, held]), np.concatenate([[0.0, 0.0], targets])):
            p.resetJointState(self.robot_id, int(j), float(q), 0.0, physicsClientId=self.client)
        self.command_joint_positions(held, targets)
        self.stop_wheels()

    def stop_wheels(self) -> None:
        """Zero the base's velocity and brake the wheels (after a kinematic base move)."""
        p.resetBaseVelocity(self.robot_id, [0, 0, 0], [0, 0, 0], physicsClientId=self.client)
        p.setJointMotorControlArray(self.robot_id, self.wheel_joint_indices.tolist(), p.VELOCITY_CONTROL,
                                    targetVelocities=[0.0, 0.0], forces=self._controlled_forces[:2].tolist(),
                                    physicsClientId=self.client)

    def set_base_pose(self, x: float, y: float, yaw: float, z: float | None = None) -> None:
        """Kinematic teleport of the base link frame; joint positions are kept."""
        self._place_base(x, y, yaw, self._base_height if z is None else z)

    def _place_base(self, x: float, y: float, yaw: float, z: float) -> None:
        link_orn = p.getQuaternionFromEuler([0.0, 0.0, yaw])
        com_pos, com_orn = p.multiplyTransforms([x, y, z], link_orn, *self._base_com_offset)
        p.resetBasePositionAndOrientation(self.robot_id, com_pos, com_orn, physicsClientId=self.client)

    def base_pose(self) -> np.ndarray:
        """``(x, y, yaw)`` of the base link frame in the world."""
        (x, y, _), orn = self.link_pose(BASE_LINK)
        return np.array([x, y, p.getEulerFromQuaternion(orn)[2]])

    def base_velocity(self) -> np.ndarray:
        """``(forward, lateral, yaw_rate)`` in the robot frame (m/s, m/s, rad/s)."""
        linear, angular = p.getBaseVelocity(self.robot_id, physicsClientId=self.client)
        yaw = self.base_pose()[2]
        c, s = np.cos(yaw), np.sin(yaw)
        return np.array([c * linear[0] + s * linear[1], -s * linear[0] + c * linear[1], angular[2]])

    # ------------------------------------------------------------------ joints

    def apply_normalized_velocity(self, action: np.ndarray) -> None:
        """Velocity targets for wheels, torso and arm from an action in ``[-1, 1]``."""
        velocities = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0) * self.velocity_limits
        p.setJointMotorControlArray(self.robot_id, self.controlled_joint_indices.tolist(), p.VELOCITY_CONTROL,
                                    targetVelocities=velocities.tolist(),
                                    forces=self._controlled_forces.tolist(), physicsClientId=self.client)

    def get_joint_positions(self, indices: Sequence[int]) -> np.ndarray:
        states = p.getJointStates(self.robot_id, list(map(int, indices)), physicsClientId=self.client)
        return np.array([s[0] for s in states])

    def set_joint_positions(self, indices: Sequence[int], values: Sequence[float]) -> None:
        """Kinematic reset of joint positions (velocities zeroed; motor targets unchanged)."""
        indices = np.asarray(indices, dtype=np.int64).tolist()
        # One multi-DoF call is 3-4x faster than a resetJointState per joint (planners call this
        # for every collision check).
        p.resetJointStatesMultiDof(self.robot_id, indices,
                                   targetValues=np.asarray(values, dtype=np.float64).reshape(-1, 1).tolist(),
                                   targetVelocities=[[0.0]] * len(indices), physicsClientId=self.client)

    def command_joint_positions(self, indices: Sequence[int], values: Sequence[float],
                                max_force: float | Sequence[float] | None = None,
                                position_gain: float = 0.3) -> None:
        """Position-control targets; ``max_force`` defaults to each joint's URDF effort."""
        indices = np.asarray(indices, dtype=np.int64)
        forces = self.joint_max_force[indices] if max_force is None else np.broadcast_to(max_force, indices.shape)
        p.setJointMotorControlArray(self.robot_id, indices.tolist(), p.POSITION_CONTROL,
                                    targetPositions=list(map(float, values)), forces=list(map(float, forces)),
                                    positionGains=[position_gain] * len(indices), physicsClientId=self.client)

    def joint_state_vector(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities of the planning chain (torso + arm), one PyBullet call."""
        states = p.getJointStates(self.robot_id, self.arm_joint_indices.tolist(), physicsClientId=self.client)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    # ------------------------------------------------------------------ frames

    def link_pose(self, link_index: int) -> tuple[np.ndarray, np.ndarray]:
        """World position and quaternion (x, y, z, w) of a link frame (URDF frame, not COM)."""
        if link_index == BASE_LINK:
            com_pos, com_orn = p.getBasePositionAndOrientation(self.robot_id, physicsClientId=self.client)
            inv_pos, inv_orn = p.invertTransform(*self._base_com_offset)
            pos, orn = p.multiplyTransforms(com_pos, com_orn, inv_pos, inv_orn)
        else:
            state = p.getLinkState(self.robot_id, link_index, computeForwardKinematics=1,
                                   physicsClientId=self.client)
            pos, orn = state[4], state[5]
        return np.array(pos), np.array(orn)

    def arm_base_position(self) -> np.ndarray:
        """World position of the first arm joint's link (where ``spec.arm_reach`` is measured from)."""
        return self.link_pose(self.joint_indices[self.spec.arm_joints[0]])[0]

    def end_effector_position(self) -> np.ndarray:
        return self.link_pose(self.end_effector_link_index)[0]

    def _position_and_rotation(self, link_index: int) -> tuple[np.ndarray, np.ndarray]:
        pos, orn = self.link_pose(link_index)
        return pos, np.array(p.getMatrixFromQuaternion(orn)).reshape(3, 3)

    def camera_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Camera position and 3x3 rotation (camera link -> world); the camera looks along +x."""
        return self._position_and_rotation(self.camera_link_index)

    def lidar_pose(self) -> tuple[np.ndarray, float]:
        """LiDAR position and the world yaw of its scan centre (+x of the LiDAR link)."""
        pos, rot = self._position_and_rotation(self.lidar_link_index)
        return pos, float(np.arctan2(rot[1, 0], rot[0, 0]))
