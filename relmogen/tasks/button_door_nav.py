"""ButtonDoorNav: press a wall button that opens a locked door, then reach the goal behind it.

Task Description:
    The same layout as PushDoorNav: the goal lies inside a closed room (``goal_region``)
    whose doorway (``scene.goal_doorway``) holds a door swinging into the room. This door
    cannot be pushed open: it is held shut by a motor no push overcomes. A button (a red cap
    on a yellow plate, 5 cm travel, spring-returned) on the corridor wall next to the door
    opens it: once the cap is pressed deeper than 3 cm the door swings open on its own (a
    fast motor; within the same subgoal step) and stays open. The robot starts in the
    corridor and must press the button with its arm, then drive through and bring its base
    centre within 0.5 m of the goal. Touching the door or the walls with the base ends
    joint-control episodes; the motion generator stops the base before any contact.

Randomizations:
    Hinge side; the button's side of the doorway, its distance from the door frame (cap
    centre 0.3-1.0 m from the jamb along the wall) and its height (0.9-1.1 m); the goal (in
    the room, at least 1.5 m from the doorway centre); the start pose (in the corridor, yaw
    uniform, geodesic distance 1.5-10 m, at least 0.8 m from the doorway centre and 0.7 m
    from the button).

Success Conditions:
    xy distance from the base centre to the goal below 0.5 m. The episode ends on success.

Reward:
    geodesic: (previous - current) geodesic distance to the goal on the static floor plan
        (doors ignored), weight 1.
    button: +5 once, when the button is first pressed (deeper than 3 cm).
    success: +10 once, when a decision (a subgoal, or a joint step) ends with the success
        condition holding (the episode ends then); passing through the goal mid-subgoal earns nothing.

Metrics:
    success (SR), spl, path_length, shortest_path_length, goal_distance, door_angle_deg
    (final), door_opened (door ever above 60 deg), button_pressed.
"""

from __future__ import annotations

import numpy as np

from relmogen.scenes.objects.door import ButtonDoor, WallButton
from relmogen.tasks.base import register_task
from relmogen.tasks.push_door_nav import SAMPLING_TRIES, PushDoorNav
from relmogen.tasks.terms import EventReward, PotentialReward

BUTTON_JAMB_DISTANCE = (0.3, 1.0)  # cap centre from the door frame, along the wall
BUTTON_HEIGHT = (0.9, 1.1)
BUTTON_HALF_SPAN = 0.12  # wall needed on either side of the button centre


def button_cap_cells(rgb: np.ndarray, cell: int) -> np.ndarray:
    """(N, 3, S, S) or (N, S, S, 3) uint8 images -> (N, S / cell, S / cell) bool: the ``cell`` x
    ``cell`` pixel blocks that hold button-cap pixels (red: R > 100, G < 60, B < 60, the only red
    in ButtonDoorNav)."""
    if rgb.shape[1] == 3:
        rgb = rgb.transpose(0, 2, 3, 1)
    red = (rgb[..., 0] > 100) & (rgb[..., 1] < 60) & (rgb[..., 2] < 60)
    n, size = red.shape[0], red.shape[1]
    q = size // cell
    return red.reshape(n, q, cell, q, cell).any(axis=(2, 4))


@register_task
class ButtonDoorNav(PushDoorNav):
    name = "ButtonDoorNav"
    button_reward = 5.0
    start_button_clearance = 0.7

    def __init__(self, ctx):
        super().__init__(ctx)
        self.mechanism: ButtonDoor | None = None
        self.reward_terms = [
            PotentialReward("geodesic", self.geodesic_distance, self.geodesic_weight),
            EventReward("button", self.button_pressed, self.button_reward),
            EventReward("success", self.is_success, self.success_reward, per_decision=True),
        ]

    def load(self) -> None:
        super().load()
        self.button = WallButton(self.ctx.world.client)
        self.mechanism = ButtonDoor(self.door, self.button)

    def object_bodies(self) -> list[int]:
        return [*super().object_bodies(), self.button.body]

    def reset_objects(self, rng: np.random.Generator) -> None:
        wall_point, out_normal = self.sample_button_spot(rng)
        hinge_side = 1 if rng.random() < 0.5 else -1
        self.mechanism.reset(hinge_side, wall_point, out_normal, rng.uniform(*BUTTON_HEIGHT))

    def sample_button_spot(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """A point on the corridor-side wall face next to the doorway with solid wall around it."""
        d = self.doorway
        out_normal = -np.asarray(d.normal) if d.regions[0] == self.ctx.scene.start_region else np.asarray(d.normal)
        face_centre = np.asarray(d.center) + 0.5 * d.wall_thickness * out_normal
        along = np.asarray(d.along)
        for _ in range(SAMPLING_TRIES):
            offset = 0.5 * d.width + rng.uniform(*BUTTON_JAMB_DISTANCE)
            point = face_centre + (offset if rng.random() < 0.5 else -offset) * along
            if self._on_solid_wall(point, out_normal, along):
                return point, out_normal
        raise RuntimeError(f"no wall next to the doorway at {d.center} for the button")

    def _on_solid_wall(self, point: np.ndarray, out_normal: np.ndarray, along: np.ndarray) -> bool:
        scene = self.ctx.scene
        depth = 0.5 * self.doorway.wall_thickness  # the wall's centre line
        behind = [point - depth * out_normal + s * along for s in (-BUTTON_HALF_SPAN, 0.0, BUTTON_HALF_SPAN)]
        front = point + 0.4 * out_normal
        walled = not np.any(scene.trav_map.is_free(np.array(behind)))
        return walled and scene.region_of(front) == scene.start_region

    def start_allowed(self, xy: np.ndarray) -> bool:
        far_from_button = np.linalg.norm(xy - self.button.face_xy) >= self.start_button_clearance
        return super().start_allowed(xy) and far_from_button

    def after_control_step(self) -> None:
        self.mechanism.update()
        super().after_control_step()

    def button_pressed(self) -> bool:
        return self.mechanism.pressed

    def metrics(self) -> dict[str, float]:
        return {**super().metrics(), "button_pressed": float(self.mechanism.pressed)}
