"""Small helpers to create primitive bodies (the project uses no meshes)."""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pybullet as p


def visual_marker(client: int, radius: float, height: float, rgba: Sequence[float]) -> int:
    """A cylinder with no collision shape: seen by cameras, never touched."""
    visual = p.createVisualShape(
        p.GEOM_CYLINDER, radius=radius, length=height, rgbaColor=list(rgba), physicsClientId=client
    )
    return p.createMultiBody(baseMass=0.0, baseVisualShapeIndex=visual, physicsClientId=client)


def move_body(client: int, body: int, xyz: Sequence[float], yaw: float = 0.0) -> None:
    orientation = p.getQuaternionFromEuler([0.0, 0.0, yaw])
    p.resetBasePositionAndOrientation(body, list(xyz), orientation, physicsClientId=client)


def movable_joints(client: int, body: int) -> list[int]:
    """Indices of the revolute and prismatic joints of ``body``."""
    return [joint for joint in range(p.getNumJoints(body, physicsClientId=client))
            if p.getJointInfo(body, joint, physicsClientId=client)[2] != p.JOINT_FIXED]


def body_pose_and_joints(client: int, body: int) -> tuple[np.ndarray, float, np.ndarray]:
    """World ``(x, y, z)`` and yaw of the base of ``body``, and the positions of its movable joints."""
    position, orientation = p.getBasePositionAndOrientation(body, physicsClientId=client)
    yaw = p.getEulerFromQuaternion(orientation)[2]
    joints = [p.getJointState(body, joint, physicsClientId=client)[0] for joint in movable_joints(client, body)]
    return np.asarray(position), float(yaw), np.asarray(joints, dtype=np.float64)
