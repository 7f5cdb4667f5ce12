"""Scripted policies that read only the public observation (useful as demos and sanity checks)."""

from __future__ import annotations

import numpy as np

from relmogen.robots.spec import EmbodimentSpec

LOOKAHEAD_WAYPOINT = 2  # the 3rd waypoint, 0.6 m ahead on the shortest path


class WaypointFollower:
    """Differential-drive pursuit of the shortest-path waypoints in a navigation ``task_obs``.

    Turns on the spot when the waypoint is off to the side, otherwise drives forward while
    steering. Outputs the 10-D normalised joint-velocity action (arm and torso still).
    """

    def __init__(self, spec: EmbodimentSpec, speed: float = 0.5, turn_gain: float = 1.5):
        self.spec, self.speed, self.turn_gain = spec, speed, turn_gain

    def __call__(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        target = obs["task_obs"][2 * LOOKAHEAD_WAYPOINT : 2 * LOOKAHEAD_WAYPOINT + 2]
        heading = float(np.arctan2(target[1], target[0]))
        forward = self.speed * max(0.0, np.cos(heading)) ** 4
        turn = self.turn_gain * heading
        half_track = 0.5 * self.spec.wheel_separation
        wheel = np.array([forward - turn * half_track, forward + turn * half_track]) / self.spec.wheel_radius
        action = np.zeros(len(self.spec.velocity_limits), dtype=np.float32)
        action[:2] = np.clip(wheel / np.asarray(self.spec.velocity_limits[:2]), -1.0, 1.0)
        return action
