"""Small helpers to create primitive bodies (the project uses no meshes)."""

from __future__ import annotations

from typing import Sequence

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
