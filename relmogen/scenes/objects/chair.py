"""A dining chair: one rigid body of boxes (seat, four legs, backrest) that the arm can push.

Local frame: origin on the floor under the seat centre, +x is the way a sitter faces (the
front), the backrest stands on the back edge of the seat (-x). The seat (0.45 m high,
0.40 x 0.40 m) passes under a 0.71 m table underside and between table legs 0.595 m apart
(about 10 cm to spare on each side); the backrest (0.85 m high, 6 cm thick) does not, so it
stops the chair at the table edge.

Physics choices: 6 kg with the centre of mass low (0.25 m) and the mass in the corner legs
(a steel frame). A horizontal push at height h slides the chair before tipping it while the
foot friction mu satisfies mu * h < d (d = 0.18 m, centre of mass to the front legs): with
mu = 0.15 (0.3 here times the floor's default 0.5; PyBullet multiplies the two) a push
anywhere on the backrest (h <= 0.85 m) slides it, and a 0.25 m push at the arm's 0.1 m/s
moves it about 0.25-0.28 m. A slippery point contact drives the chair along its own heading
and an off-centre contact turns it (about 0.15 rad per 0.25 m push at 5 cm off-centre).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p

from relmogen.simulation.shapes import box_collision_shape, record_body

RGBA = tuple[float, float, float, float]
CHAIR_RGBA: RGBA = (0.10, 0.55, 0.70, 1.0)  # teal blue: unlike the wooden table and floor


@dataclass(frozen=True)
class ChairGeometry:
    seat_depth: float = 0.40
    seat_width: float = 0.40
    seat_height: float = 0.45  # top of the seat
    seat_thickness: float = 0.04
    leg_size: float = 0.035
    back_thickness: float = 0.06  # thicker than the gripper may sink in (3 cm): it cannot straddle it
    back_top: float = 0.85
    mass: float = 6.0
    com_height: float = 0.25
    friction: float = 0.3  # times the floor's default 0.5 -> 0.15 at the feet

    def inertia(self) -> tuple[float, float, float]:
        """Principal moments about the centre of mass with the mass in the legs (steel-framed
        chair): a gripper touching the backrest off-centre barely spins it."""
        leg_x, leg_y = 0.5 * (self.seat_depth - self.leg_size), 0.5 * (self.seat_width - self.leg_size)
        z = self.com_height
        return (self.mass * (leg_y ** 2 + z ** 2), self.mass * (leg_x ** 2 + z ** 2),
                self.mass * (leg_x ** 2 + leg_y ** 2))

    @property
    def back_face_x(self) -> float:
        """Local x of the backrest's outer (rear) face."""
        return -0.5 * self.seat_depth

    @property
    def back_inner_x(self) -> float:
        """Local x of the backrest's front face (what meets a table edge)."""
        return -0.5 * self.seat_depth + self.back_thickness

    def boxes(self) -> list[tuple[tuple[float, float, float], tuple[float, float, float]]]:
        """(centre, half extents) of every box, local frame."""
        d, w, h, t, leg = (0.5 * self.seat_depth, 0.5 * self.seat_width, self.seat_height,
                           self.seat_thickness, 0.5 * self.leg_size)
        leg_h = 0.5 * (h - t)
        boxes = [((0.0, 0.0, h - 0.5 * t), (d, w, 0.5 * t))]
        boxes += [((sx * (d - leg), sy * (w - leg), leg_h), (leg, leg, leg_h)) for sx in (-1, 1) for sy in (-1, 1)]
        back_half_h = 0.5 * (self.back_top - h)
        boxes.append(((-d + 0.5 * self.back_thickness, 0.0, h + back_half_h), (0.5 * self.back_thickness, w,
                                                                               back_half_h)))
        return boxes


CHAIR = ChairGeometry()


class Chair:
    """A spawned chair; create once, then re-pose with ``set_pose`` every episode."""

    def __init__(self, client: int, geometry: ChairGeometry = CHAIR, rgba: RGBA = CHAIR_RGBA):
        self.client, self.geometry = client, geometry
        self.body_id = self._spawn(rgba)

    def _spawn(self, rgba: RGBA) -> int:
        g, client = self.geometry, self.client
        centres, halves = zip(*g.boxes())
        n = len(centres)
        collision = box_collision_shape(client, halves, centres, compound=True)
        visual = p.createVisualShapeArray([p.GEOM_BOX] * n, halfExtents=list(halves),
                                          visualFramePositions=list(centres), rgbaColors=[list(rgba)] * n,
                                          physicsClientId=client)
        body = record_body(client, p.createMultiBody(g.mass, collision, visual, [0, 0, 0],
                                                     baseInertialFramePosition=[0.0, 0.0, g.com_height],
                                                     physicsClientId=client), {-1: collision},
                           base_inertial_position=(0.0, 0.0, g.com_height))
        p.changeDynamics(body, -1, lateralFriction=g.friction, spinningFriction=0.0, rollingFriction=0.0,
                         linearDamping=0.0, angularDamping=0.0, localInertiaDiagonal=g.inertia(),
                         physicsClientId=client)
        return body

    def set_pose(self, xy, yaw: float) -> None:
        """Stand the chair at ``xy`` facing ``yaw``, at rest."""
        orientation = p.getQuaternionFromEuler([0.0, 0.0, float(yaw)])
        # PyBullet places the inertial frame, which sits com_height above the link frame.
        com = [float(xy[0]), float(xy[1]), self.geometry.com_height]
        p.resetBasePositionAndOrientation(self.body_id, com, orientation, physicsClientId=self.client)
        p.resetBaseVelocity(self.body_id, [0, 0, 0], [0, 0, 0], physicsClientId=self.client)

    def position(self) -> np.ndarray:
        """World xyz of the local-frame origin (floor under the seat centre when upright)."""
        position, _ = self._frame()
        return position

    def pose(self) -> tuple[float, float, float]:
        """World (x, y, yaw)."""
        position, rotation = self._frame()
        return float(position[0]), float(position[1]), float(np.arctan2(rotation[1, 0], rotation[0, 0]))

    def tilt(self) -> float:
        """Angle (rad) between the chair's up axis and the world vertical."""
        _, rotation = self._frame()
        return float(np.arccos(np.clip(rotation[2, 2], -1.0, 1.0)))

    def to_world(self, local_xyz) -> np.ndarray:
        position, rotation = self._frame()
        return position + rotation @ np.asarray(local_xyz, dtype=np.float64)

    def backrest_point(self, height: float) -> np.ndarray:
        """World point on the middle of the backrest's rear face at ``height`` above the floor."""
        return self.to_world((self.geometry.back_face_x, 0.0, height))

    def _frame(self) -> tuple[np.ndarray, np.ndarray]:
        """World position of the link frame and its rotation matrix (PyBullet reports the
        inertial frame, which sits ``com_height`` above the link frame)."""
        com, orientation = p.getBasePositionAndOrientation(self.body_id, physicsClientId=self.client)
        rotation = np.array(p.getMatrixFromQuaternion(orientation)).reshape(3, 3)
        return np.asarray(com) - rotation @ np.array([0.0, 0.0, self.geometry.com_height]), rotation
