"""A hinged door panel for a doorway, a spring-loaded wall button, and the two combined.

``HingedDoor`` (one PyBullet multibody, created once, re-posed per episode):

* base: no shape, mass 0 (fixed), at the hinge axis at the door's mid-height;
* link 0: the panel with a horizontal push bar on its outward face (the robot pushes the bar:
  it stands off the panel, so the gripper can touch it without the wrist touching the door),
  revolute about the vertical hinge axis; 0 = closed (in the doorway plane), positive angles
  swing it into ``doorway.regions[1]`` (the goal room), radians.

Body frame: x points out of the room (``-doorway.normal``), y from the hinge along the closed
panel, z = x cross y. With the hinge on the doorway's ``+along`` side z points up; on the
``-along`` side the frame is rolled upside down (z down), which mirrors the door while the
same positive joint angles still open it into the room. The panel is symmetric in height, so
the roll changes nothing else.

Joint physics: limits via ``changeDynamics``; dry friction as a zero-velocity motor with a
small maximum force (a still door stays put, the arm's push of tens of newtons moves it).
``lock`` swaps that for a motor no robot can overcome; ``drive_open`` for a strong, fast
position motor (the automatic door of ButtonDoorNav).

``WallButton``: a fixed plate on a wall face with a square cap on a prismatic joint pushed
into the wall (0 = rest, + = pressed, metres, 5 cm travel), returned by a weak position motor
(the spring). ``ButtonDoor`` latches the first press beyond ``PRESS_DEPTH`` and opens the door.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as p

from relmogen.scenes.geometry import Doorway
from relmogen.simulation.shapes import box_collision_shape, record_body

PANEL_THICKNESS = 0.04
HINGE_INSET = 0.03  # hinge axis from the hinge-side jamb (clears the jamb at any angle)
HINGE_GAP = 0.01  # panel starts this far from the axis
LATCH_GAP = 0.01  # between the closed panel's free edge and the latch-side jamb
FLOOR_GAP, TOP_GAP = 0.02, 0.04
DOOR_LIMITS = (0.0, math.radians(100.0))
OPEN_ANGLE = math.radians(60.0)  # "door counted open above 60 deg"
BAR_RADII = (0.30, 0.90)  # push bar span, metres from the hinge axis
BAR_DEPTH, BAR_HEIGHT = 0.06, 0.05  # how far it stands off the face; its vertical size
DOOR_RGBA = (0.20, 0.42, 0.68, 1.0)  # blue, unlike the off-white walls and brown furniture
BAR_RGBA = (0.80, 0.80, 0.84, 1.0)  # brushed steel


@dataclass(frozen=True)
class DoorPhysics:
    mass: float = 8.0  # kg
    friction: float = 3.0  # N m, zero-velocity motor: holds still, yields to the arm
    lock_torque: float = 1e4  # N m, locked door: more than anything in the scene can apply
    open_target: float = math.radians(92.0)
    open_speed: float = 4.0  # rad/s of the automatic door's motor
    open_torque: float = 2000.0  # N m


def _door_shapes(client: int, panel_half, bar_half, panel_offset, bar_offset) -> tuple[int, int]:
    half, offsets = [list(panel_half), list(bar_half)], [list(panel_offset), list(bar_offset)]
    visual = p.createVisualShapeArray([p.GEOM_BOX] * 2, halfExtents=half, visualFramePositions=offsets,
                                      rgbaColors=[list(DOOR_RGBA), list(BAR_RGBA)], physicsClientId=client)
    return box_collision_shape(client, half, offsets), visual


def _panel_shapes(client: int, half_extents, offset, rgba) -> tuple[int, int]:
    visual = p.createVisualShape(p.GEOM_BOX, halfExtents=list(half_extents), visualFramePosition=list(offset),
                                 rgbaColor=list(rgba), physicsClientId=client)
    return box_collision_shape(client, [half_extents], [offset]), visual


def _frame_quaternion(x_axis: np.ndarray, y_axis: np.ndarray) -> tuple[float, ...]:
    """Quaternion of the frame with horizontal x and y axes: a yaw, rolled by pi when
    x cross y points down."""
    roll = 0.0 if x_axis[0] * y_axis[1] - x_axis[1] * y_axis[0] > 0 else math.pi
    return p.getQuaternionFromEuler([roll, 0.0, math.atan2(x_axis[1], x_axis[0])])


class HingedDoor:
    """A door in ``doorway`` swinging into ``doorway.regions[1]``; see the module docstring."""

    def __init__(self, client: int, doorway: Doorway, physics: DoorPhysics | None = None):
        self.client, self.doorway = client, doorway
        self.physics = physics or DoorPhysics()
        self.length = doorway.width - HINGE_INSET - HINGE_GAP - LATCH_GAP
        self.height = doorway.height - FLOOR_GAP - TOP_GAP
        self.body = self._create()
        p.changeDynamics(self.body, 0, jointLowerLimit=DOOR_LIMITS[0], jointUpperLimit=DOOR_LIMITS[1],
                         lateralFriction=0.6, physicsClientId=client)
        self.hinge_side = 1
        self.place(1)

    def _create(self) -> int:
        half = (0.5 * PANEL_THICKNESS, 0.5 * self.length, 0.5 * self.height)
        bar_half = (0.5 * BAR_DEPTH, 0.5 * (BAR_RADII[1] - BAR_RADII[0]), 0.5 * BAR_HEIGHT)
        bar_offset = (half[0] + bar_half[0], 0.5 * sum(BAR_RADII), 0.0)
        collision, visual = _door_shapes(self.client, half, bar_half, (0.0, HINGE_GAP + half[1], 0.0), bar_offset)
        return record_body(self.client, p.createMultiBody(
            baseMass=0.0, basePosition=[0, 0, -10], linkMasses=[self.physics.mass],
            linkCollisionShapeIndices=[collision], linkVisualShapeIndices=[visual],
            linkPositions=[[0, 0, 0]], linkOrientations=[[0, 0, 0, 1]],
            linkInertialFramePositions=[[0.0, HINGE_GAP + half[1], 0.0]],
            linkInertialFrameOrientations=[[0, 0, 0, 1]], linkParentIndices=[0],
            linkJointTypes=[p.JOINT_REVOLUTE], linkJointAxis=[[0, 0, 1]], physicsClientId=self.client), {0: collision})

    # ------------------------------------------------------------------ pose
    def place(self, hinge_side: int) -> None:
        """Put the door closed in its doorway, hinged on the ``+along`` (1) or ``-along``
        (-1) jamb, with the friction motor on."""
        d = self.doorway
        self.hinge_side = 1 if hinge_side >= 0 else -1
        hinge = np.asarray(d.center) + self.hinge_side * (0.5 * d.width - HINGE_INSET) * d.along
        self.closed_direction = -self.hinge_side * d.along  # hinge -> free edge, closed
        self.hinge_xy = hinge
        orientation = _frame_quaternion(-d.normal, self.closed_direction)
        z = FLOOR_GAP + 0.5 * self.height
        p.resetBasePositionAndOrientation(self.body, [*hinge, z], orientation, physicsClientId=self.client)
        self.set_angle(0.0)
        self.release()

    def set_angle(self, angle: float) -> None:
        p.resetJointState(self.body, 0, float(angle), 0.0, physicsClientId=self.client)

    @property
    def angle(self) -> float:
        return float(p.getJointState(self.body, 0, physicsClientId=self.client)[0])

    def is_open(self) -> bool:
        return self.angle > OPEN_ANGLE

    def panel_direction(self, angle: float | None = None) -> np.ndarray:
        """Unit xy vector from the hinge along the panel at ``angle`` (default: current)."""
        a = self.angle if angle is None else angle
        return math.cos(a) * self.closed_direction + math.sin(a) * np.asarray(self.doorway.normal)

    def face_normal(self, angle: float | None = None) -> np.ndarray:
        """Unit xy normal of the panel face that looks out of the room when closed."""
        a = self.angle if angle is None else angle
        return math.sin(a) * self.closed_direction - math.cos(a) * np.asarray(self.doorway.normal)

    def face_point(self, radius: float, height: float, angle: float | None = None) -> np.ndarray:
        """World point on the outward face, ``radius`` m from the hinge axis, at ``height``."""
        xy = (self.hinge_xy + radius * self.panel_direction(angle)
              + 0.5 * PANEL_THICKNESS * self.face_normal(angle))
        return np.array([xy[0], xy[1], height])

    @property
    def bar_height(self) -> float:
        return FLOOR_GAP + 0.5 * self.height

    def bar_point(self, radius: float, angle: float | None = None) -> np.ndarray:
        """World point at the middle of the push bar's front, ``radius`` m from the hinge axis
        (on the bar for ``radius`` in ``BAR_RADII``)."""
        point = self.face_point(radius, self.bar_height, angle)
        point[:2] += BAR_DEPTH * self.face_normal(angle)
        return point

    def panel_segment(self, angle: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Hinge-end and free-end xy of the panel's centre line."""
        direction = self.panel_direction(angle)
        return self.hinge_xy + HINGE_GAP * direction, self.hinge_xy + (HINGE_GAP + self.length) * direction

    # ------------------------------------------------------------------ motors
    def _velocity_motor(self, max_torque: float) -> None:
        p.setJointMotorControl2(self.body, 0, p.VELOCITY_CONTROL, targetVelocity=0.0, force=max_torque,
                                physicsClientId=self.client)

    def release(self) -> None:
        """Free door with dry friction (the push door)."""
        self._velocity_motor(self.physics.friction)

    def lock(self) -> None:
        """Held shut by a motor no push can overcome (the button door before the press)."""
        self._velocity_motor(self.physics.lock_torque)

    def drive_open(self) -> None:
        """A strong, fast position motor swings the door to ``open_target`` and holds it."""
        ph = self.physics
        p.setJointMotorControl2(self.body, 0, p.POSITION_CONTROL, targetPosition=ph.open_target,
                                force=ph.open_torque, maxVelocity=ph.open_speed, positionGain=0.5,
                                physicsClientId=self.client)


BUTTON_TRAVEL = 0.05
PRESS_DEPTH = 0.03
# x = out of the wall. The plate is narrower than the open gripper's finger gap and the cap
# stands 10 cm proud, so fingers straddling the cap never reach the plate before the press.
PLATE_HALF = (0.0075, 0.055, 0.055)
CAP_HALF = (0.05, 0.035, 0.035)
PLATE_RGBA = (1.0, 0.85, 0.0, 1.0)  # bright yellow
CAP_RGBA = (0.9, 0.05, 0.05, 1.0)  # red
SPRING_FORCE = 8.0  # N, the return motor's maximum force
BUTTON_MASS = 0.1


class WallButton:
    """A push button on a wall; body x axis points out of the wall, the cap slides along -x."""

    def __init__(self, client: int):
        self.client = client
        self.body = self._create()
        p.changeDynamics(self.body, 0, jointLowerLimit=0.0, jointUpperLimit=BUTTON_TRAVEL,
                         physicsClientId=client)
        p.setJointMotorControl2(self.body, 0, p.POSITION_CONTROL, targetPosition=0.0, force=SPRING_FORCE,
                                positionGain=0.2, physicsClientId=client)
        self.face_xy, self.out_normal, self.height = np.zeros(2), np.array([1.0, 0.0]), 1.0

    def _create(self) -> int:
        c = self.client
        plate = _panel_shapes(c, PLATE_HALF, (0.0, 0.0, 0.0), PLATE_RGBA)
        cap = _panel_shapes(c, CAP_HALF, (CAP_HALF[0], 0.0, 0.0), CAP_RGBA)
        return record_body(c, p.createMultiBody(
            baseMass=0.0, baseCollisionShapeIndex=plate[0], baseVisualShapeIndex=plate[1],
            basePosition=[0, 0, -10], linkMasses=[BUTTON_MASS], linkCollisionShapeIndices=[cap[0]],
            linkVisualShapeIndices=[cap[1]], linkPositions=[[PLATE_HALF[0], 0, 0]],
            linkOrientations=[[0, 0, 0, 1]], linkInertialFramePositions=[[CAP_HALF[0], 0, 0]],
            linkInertialFrameOrientations=[[0, 0, 0, 1]], linkParentIndices=[0],
            linkJointTypes=[p.JOINT_PRISMATIC], linkJointAxis=[[-1, 0, 0]], physicsClientId=c),
            {-1: plate[0], 0: cap[0]})

    def place(self, wall_point_xy, out_normal_xy, height: float) -> None:
        """Mount the plate on the wall face at ``wall_point_xy``; ``out_normal_xy`` points
        away from the wall; the cap is released."""
        n = np.asarray(out_normal_xy, dtype=np.float64)
        self.out_normal, self.height = n / np.linalg.norm(n), float(height)
        centre = np.asarray(wall_point_xy, dtype=np.float64) + (PLATE_HALF[0] + 1e-3) * self.out_normal
        along = np.array([-self.out_normal[1], self.out_normal[0]])
        p.resetBasePositionAndOrientation(self.body, [*centre, self.height],
                                          _frame_quaternion(self.out_normal, along), physicsClientId=self.client)
        p.resetJointState(self.body, 0, 0.0, 0.0, physicsClientId=self.client)
        self.face_xy = centre + (PLATE_HALF[0] + 2 * CAP_HALF[0]) * self.out_normal

    @property
    def depth(self) -> float:
        """How far the cap is pushed in, metres (0 at rest, ``BUTTON_TRAVEL`` at the stop)."""
        return float(p.getJointState(self.body, 0, physicsClientId=self.client)[0])

    def face_centre(self) -> np.ndarray:
        """World point at the centre of the cap's face at rest (what to press)."""
        return np.array([*self.face_xy, self.height])


class ButtonDoor:
    """A locked door that swings open on its own once the button is pressed past PRESS_DEPTH.

    Call ``update`` after every control step. The door's motor opens it over a fraction of a
    second of physics; if a press comes so late in an arm push that physics stops before the
    door is open, the next ``update`` that sees no physics progress finishes the swing
    kinematically, so a press is never lost to the kinematic base motion.
    """

    def __init__(self, door: HingedDoor, button: WallButton):
        self.door, self.button = door, button
        self.pressed = False
        self._last_angle = 0.0

    def reset(self, hinge_side: int, wall_point_xy, out_normal_xy, height: float) -> None:
        self.door.place(hinge_side)
        self.door.lock()
        self.button.place(wall_point_xy, out_normal_xy, height)
        self.pressed = False
        self._last_angle = 0.0

    def update(self) -> None:
        angle = self.door.angle
        if not self.pressed and self.button.depth > PRESS_DEPTH:
            self.pressed = True
            self.door.drive_open()
        elif self.pressed and abs(angle - self._last_angle) < 1e-7 and angle < self.door.physics.open_target - 0.02:
            self.door.set_angle(self.door.physics.open_target)
            angle = self.door.physics.open_target
        self._last_angle = angle
