"""PushDoorNav oracle: drive to the door, push its bar open in a few strokes, drive through.

Privileged state: the door's hinge, angle and bar. Each stroke pushes the bar 0.45-0.55 m
from the hinge along the chord of the arc it should sweep (about 30-40 deg per 0.25 m push),
from a base pose in the corridor that puts the bar about 0.7 m ahead of the base centre.
Once the door is past 80 deg the robot lines up 0.6 m before the doorway, drives to a point
1 m inside the room beside the door, then follows the shortest path to the goal. A subgoal that changes nothing (no plan,
blocked push) makes the next one vary the stroke or the base pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from relmogen.agents.oracles.base import (
    Oracle,
    arm_action,
    base_action,
    register_oracle,
    wrap,
)
from relmogen.agents.oracles.point_nav import LOOKAHEADS
from relmogen.scenes.navigation import GeodesicField

PUSH_LENGTH = 0.25
DOOR_DONE = math.radians(80.0)  # push until here; the door counts as open from 60 deg
STROKE_RADII = (0.45, 0.55, 0.40, 0.65)  # m from the hinge; later entries after failures
REACHES = (0.7, 0.62, 0.78)  # desired base-centre-to-bar distance
ARRIVED_XY, ARRIVED_YAW = 0.1, 0.2
CLOSE_ENOUGH_XY = 0.35  # push from here when driving closer keeps failing
DIRECT_RANGE = 1.8  # drive straight at targets nearer than this
ENTRY_DEPTH, INSIDE_DEPTH = 0.6, 1.0  # lining-up point before the doorway, first point after it
MAX_BEARING = math.radians(70.0)  # turn in place first toward targets further to the side


@dataclass(frozen=True)
class Stroke:
    point: np.ndarray  # world point on the push bar
    push: np.ndarray  # world push vector (horizontal, PUSH_LENGTH long)
    base_xy: np.ndarray
    base_yaw: float


def plan_stroke(door, attempt: int = 0) -> Stroke:
    """Where to push the door at its current angle and where to stand for it."""
    angle = door.angle
    radius = STROKE_RADII[attempt % len(STROKE_RADII)] + (0.1 if angle > 0.7 else 0.0)
    sweep = PUSH_LENGTH / radius
    middle = angle + 0.5 * sweep
    chord = -math.sin(middle) * door.closed_direction + math.cos(middle) * np.asarray(door.doorway.normal)
    point = door.bar_point(radius)
    reach = REACHES[(attempt // len(STROKE_RADII)) % len(REACHES)]
    base_xy = _stand_point(door, point[:2], reach)
    yaw = math.atan2(point[1] - base_xy[1], point[0] - base_xy[0])
    return Stroke(point, np.array([*(PUSH_LENGTH * chord), 0.0]), base_xy, yaw)


def _stand_point(door, target_xy: np.ndarray, reach: float) -> np.ndarray:
    """A corridor spot in front of the doorway about ``reach`` from ``target_xy``."""
    normal = np.asarray(door.doorway.normal)
    candidates = [door.hinge_xy + along * door.closed_direction - depth * normal
                  for depth in (0.45, 0.55, 0.65) for along in np.linspace(0.3, 0.9, 7)]
    return min(candidates, key=lambda xy: abs(float(np.linalg.norm(target_xy - xy)) - reach))


def drive_to(env, field: GeodesicField, target_xy: np.ndarray, target_yaw: float | None,
             attempt: int = 0) -> np.ndarray:
    """One base subgoal toward a pose: straight at it when near, else along ``field``; a
    target far to the side is faced first (the LiDAR sees little beside and behind)."""
    x, y, yaw = env.robot.base_pose()
    final = np.linalg.norm(target_xy - (x, y)) <= DIRECT_RANGE and attempt % 2 == 0
    if final:
        aim, aim_yaw = np.asarray(target_xy), target_yaw
    else:
        n = LOOKAHEADS[min(attempt, len(LOOKAHEADS) - 1)]
        waypoints = field.waypoints((x, y), 12, 0.2)
        aim = waypoints[n - 1]
        onward = waypoints[min(n + 1, len(waypoints) - 1)] - aim
        aim_yaw = float(np.arctan2(onward[1], onward[0])) if np.linalg.norm(onward) > 1e-6 else target_yaw
    bearing = math.atan2(aim[1] - y, aim[0] - x)
    if np.linalg.norm(aim - (x, y)) > 0.3 and abs(wrap(bearing - yaw)) > MAX_BEARING:
        return base_action(env, (x, y), bearing)
    return base_action(env, aim, aim_yaw)


def at_pose(env, xy: np.ndarray, yaw: float, tolerance_xy: float = ARRIVED_XY) -> bool:
    x, y, heading = env.robot.base_pose()
    return np.hypot(x - xy[0], y - xy[1]) <= tolerance_xy and abs(wrap(heading - yaw)) <= ARRIVED_YAW


class DoorOracle(Oracle):
    """Shared parts: progress bookkeeping, the field to the staging area, going through."""

    def reset(self) -> None:
        task = self.env.task
        self.attempt = 0
        self._last_state = None
        self.lined_up = False
        centre, normal = np.asarray(task.doorway.center), np.asarray(task.doorway.normal)
        self.entry_xy = centre - ENTRY_DEPTH * normal
        self.inside_xy = centre + INSIDE_DEPTH * normal + 0.1 * task.door.closed_direction
        self.staging_field = self.env.scene.geodesic_field(self.staging_xy(), self.env.robot.spec.base_radius)

    def staging_xy(self) -> np.ndarray:
        raise NotImplementedError

    def _track_progress(self) -> None:
        """``attempt`` counts consecutive subgoals that moved neither the robot nor the door."""
        x, y, yaw = self.env.robot.base_pose()
        state = np.array([x, y, yaw, self.env.task.door.angle])
        if self._last_state is None:
            stuck = False
        else:
            change = np.abs(state - self._last_state)
            stuck = np.hypot(*change[:2]) < 0.03 and abs(wrap(change[2])) < 0.1 and change[3] < 0.01
        self.attempt = self.attempt + 1 if stuck else 0
        self._last_state = state

    def go_through(self) -> np.ndarray:
        """Line up in front of the doorway, drive 1 m into the room, then to the goal."""
        env, task = self.env, self.env.task
        xy = env.robot.base_pose()[:2]
        yaw = float(task.doorway.yaw)
        past_door = np.dot(xy - task.doorway.center, task.doorway.normal) > 0.5 * INSIDE_DEPTH
        if past_door:
            return drive_to(env, task.field, task.goal_xy, None, self.attempt)
        self.lined_up = self.lined_up or np.linalg.norm(xy - self.entry_xy) < 0.25
        if self.lined_up:
            return drive_to(env, task.field, self.inside_xy, yaw, 2 * self.attempt)
        return drive_to(env, task.field, self.entry_xy, yaw, self.attempt)


@register_oracle
class PushDoorNavOracle(DoorOracle):
    task_name = "PushDoorNav"

    def staging_xy(self) -> np.ndarray:
        return plan_stroke(self.env.task.door).base_xy

    def act(self, obs: dict) -> np.ndarray:
        self._track_progress()
        env, door = self.env, self.env.task.door
        if door.angle >= DOOR_DONE:
            return self.go_through()
        stroke = plan_stroke(door, self.attempt // 2)
        near = at_pose(env, stroke.base_xy, stroke.base_yaw,
                       CLOSE_ENOUGH_XY if self.attempt >= 2 else ARRIVED_XY)
        if not near:
            return drive_to(env, self.staging_field, stroke.base_xy, stroke.base_yaw, self.attempt)
        action = arm_action(env, stroke.point, stroke.push)
        if action is None:  # bar out of view: face it
            return base_action(env, env.robot.base_pose()[:2], stroke.base_yaw)
        return action
