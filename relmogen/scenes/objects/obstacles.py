"""Movable box obstacles (InteractiveObstaclesNav): 0.7 x 0.7 x 1.2 m, one rigid box each.

Two kinds that look alike except for their colour (paper A.1): a RED one of 1 kg that the
arm can push and a GREEN one of 1e4 kg that nothing the robot does can move.

Physics choices. A horizontal push at height h slides a box of half width d = 0.35 m before
tipping it when the floor friction mu satisfies mu * h < d: the red box's 0.6 times the
floor's default 0.5 (PyBullet multiplies the two) gives mu = 0.3, so any push up to about
1.1 m high slides it. At the arm's push speed (0.25 m in 2.5 s) the box stops within a few
millimetres of where the gripper leaves it (deceleration mu * g = 3 m/s^2). The green box's
1e4 kg with mu = 0.5 needs ~50 kN to slide, far beyond the arm's joint efforts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p

from relmogen.simulation.frames import to_local
from relmogen.simulation.shapes import box_collision_shape, record_body

RGBA = tuple[float, float, float, float]
OBSTACLE_SIZE = (0.7, 0.7, 1.2)  # x, y, z metres
RED_RGBA: RGBA = (0.85, 0.08, 0.08, 1.0)
GREEN_RGBA: RGBA = (0.08, 0.65, 0.12, 1.0)


@dataclass(frozen=True)
class ObstacleSpec:
    name: str
    mass: float  # kg
    friction: float  # lateral friction coefficient (times the floor's 0.5)
    rgba: RGBA
    size: tuple[float, float, float] = OBSTACLE_SIZE


LIGHT_OBSTACLE = ObstacleSpec("red", 1.0, 0.6, RED_RGBA)
HEAVY_OBSTACLE = ObstacleSpec("green", 1.0e4, 1.0, GREEN_RGBA)


class BoxObstacle:
    """A spawned obstacle; created once, re-posed every episode with ``set_pose``."""

    def __init__(self, client: int, spec: ObstacleSpec):
        self.client, self.spec = client, spec
        self.half_extents = np.asarray(spec.size, dtype=np.float64) / 2.0
        self.body_id = self._spawn()

    def _spawn(self) -> int:
        half, client = self.half_extents.tolist(), self.client
        collision = box_collision_shape(client, [half])
        visual = p.createVisualShape(p.GEOM_BOX, halfExtents=half, rgbaColor=list(self.spec.rgba),
                                     physicsClientId=client)
        body = record_body(client, p.createMultiBody(self.spec.mass, collision, visual, [0, 0, -10.0],
                                                     physicsClientId=client), {-1: collision})
        p.changeDynamics(body, -1, lateralFriction=self.spec.friction, spinningFriction=0.0, rollingFriction=0.0,
                         linearDamping=0.0, angularDamping=0.0, physicsClientId=client)
        return body

    def set_pose(self, xy, yaw: float) -> None:
        """Stand the box on the floor at ``xy`` with heading ``yaw``, at rest."""
        position = [float(xy[0]), float(xy[1]), float(self.half_extents[2])]
        orientation = p.getQuaternionFromEuler([0.0, 0.0, float(yaw)])
        p.resetBasePositionAndOrientation(self.body_id, position, orientation, physicsClientId=self.client)
        p.resetBaseVelocity(self.body_id, [0, 0, 0], [0, 0, 0], physicsClientId=self.client)

    def position(self) -> np.ndarray:
        return np.asarray(p.getBasePositionAndOrientation(self.body_id, physicsClientId=self.client)[0])

    def yaw(self) -> float:
        orientation = p.getBasePositionAndOrientation(self.body_id, physicsClientId=self.client)[1]
        return float(p.getEulerFromQuaternion(orientation)[2])

    def pose2d(self) -> tuple[np.ndarray, float]:
        return self.position()[:2], self.yaw()


def footprint_mask(points: np.ndarray, center_xy, yaw: float, half_xy, margin: float = 0.0) -> np.ndarray:
    """Which of ``points`` (..., 2) lie inside a box footprint grown by ``margin``."""
    local = to_local(points, (*np.asarray(center_xy)[:2], yaw))
    local_x, local_y = local[..., 0], local[..., 1]
    return (np.abs(local_x) <= half_xy[0] + margin) & (np.abs(local_y) <= half_xy[1] + margin)
