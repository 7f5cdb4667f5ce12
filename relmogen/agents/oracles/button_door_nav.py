"""ButtonDoorNav oracle: drive in front of the button, press it, drive through the opened door.

Privileged state: the button's position and whether it was pressed. The robot stands about
0.65 m from the wall facing the button and pushes the cap's centre 0.2 m into the wall (the
cap has 5 cm of travel; past 3 cm the door opens on its own). A failed press makes the next
one stand a little nearer or further away.
"""

from __future__ import annotations

import math

import numpy as np

from relmogen.agents.oracles.base import arm_action, base_action, register_oracle
from relmogen.agents.oracles.push_door_nav import (
    ARRIVED_XY,
    CLOSE_ENOUGH_XY,
    DoorOracle,
    at_pose,
    drive_to,
)

PRESS_LENGTH = 0.2
STAND_OFF = (0.65, 0.55, 0.75)  # base centre to the wall, metres


@register_oracle
class ButtonDoorNavOracle(DoorOracle):
    task_name = "ButtonDoorNav"

    def staging_xy(self, attempt: int = 0) -> np.ndarray:
        button = self.env.task.button
        return button.face_xy + STAND_OFF[attempt % len(STAND_OFF)] * button.out_normal

    def act(self, obs: dict) -> np.ndarray:
        self._track_progress()
        env, task = self.env, self.env.task
        if task.button_pressed():
            return self.go_through()
        button = task.button
        stand_xy = self.staging_xy(self.attempt // 2)
        facing = math.atan2(-button.out_normal[1], -button.out_normal[0])
        tolerance = CLOSE_ENOUGH_XY if self.attempt >= 2 else ARRIVED_XY
        if not at_pose(env, stand_xy, facing, tolerance):
            return drive_to(env, self.staging_field, stand_xy, facing, self.attempt)
        action = arm_action(env, button.face_centre(), -PRESS_LENGTH * np.append(button.out_normal, 0.0))
        if action is None:  # button out of view: face it
            return base_action(env, env.robot.base_pose()[:2], facing)
        return action
