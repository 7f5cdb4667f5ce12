"""ArrangeChairMM oracle: stand behind each chair, push its backrest straight under the table.

Privileged information: the chair poses and their tucked poses. Per chair (nearest first):
drive to a stance on the chair's gap line, ``STANDOFF`` behind the backrest and facing the
table (round the table through detour corners when it is in the way); then push the
backrest along the gap normal by the remaining distance (at most 0.25 m). The contact point
is shifted off the backrest's middle to steer: the chair slides along its own heading, so
the oracle turns it toward a heading that also removes its sideways offset. Repeat until the
chair is within ``DONE`` of tucked; a chair without progress for ``MAX_TRIES`` subgoals is
skipped.
"""

from __future__ import annotations

import numpy as np

from relmogen.agents.oracles.base import (
    Oracle,
    arm_action,
    base_action,
    register_oracle,
    wrap,
)
from relmogen.scenes.geometry import Table

STANDOFF = 0.8  # robot centre to the backrest's rear face, metres
PUSH_HEIGHT = 0.72  # on the backrest, metres above the floor
STANCE_TOLERANCE = (0.08, 0.12)  # metres, rad: close enough to push from
DONE = 0.05  # a chair this close to tucked is left alone (the tight tolerance)
OVERSHOOT = 0.02  # push this much past tucked (the table edge stops the backrest)
MAX_TRIES = 8  # subgoals spent on one chair without progress before skipping it
STEER_GAIN = 0.35  # backrest contact offset (m) per rad of heading error (~0.15 rad per push at 5 cm)
MAX_STEER = 0.2  # rad: the largest heading asked for to cancel a sideways offset
MAX_CONTACT = 0.12  # m from the backrest middle
MAX_DRIVE_BEARING = 1.0  # rad: targets further off the heading are faced first
TABLE_KEEPOUT = 0.3  # a base path leg must stay this far outside the table top (robot radius)
CORNER_OFFSET = (0.9, 1.2)  # detour corners beyond the table's ends and long sides, metres


@register_oracle
class ArrangeChairOracle(Oracle):
    task_name = "ArrangeChairMM"

    def reset(self) -> None:
        self.target: int | None = None
        self.tries = 0
        self.best = np.inf
        self.skipped: set[int] = set()

    def act(self, obs: dict) -> np.ndarray:
        chair = self._choose_chair()
        if chair is None:
            return base_action(self.env, self.env.robot.base_pose()[:2])  # nothing left: stay
        stance_xy, stance_yaw = self._stance(chair)
        x, y, yaw = self.env.robot.base_pose()
        off = np.hypot(*(stance_xy - (x, y))), abs(wrap(stance_yaw - yaw))
        if off[0] > STANCE_TOLERANCE[0] or off[1] > STANCE_TOLERANCE[1]:
            waypoint = next_waypoint(self.env.scene.table, np.array([x, y]), stance_xy)
            if waypoint is not None:
                return drive(self.env, waypoint)
            return drive(self.env, stance_xy, stance_yaw)
        action = self._push(chair)
        return action if action is not None else drive(self.env, stance_xy, stance_yaw)

    # ------------------------------------------------------------------ choosing
    def _choose_chair(self) -> int | None:
        task = self.env.task
        distances = task.tuck_distances()
        if self.target is not None:
            self._track_progress(distances[self.target])
        if self.target is None or distances[self.target] < DONE or self.target in self.skipped:
            left = [i for i in range(len(distances)) if distances[i] >= DONE and i not in self.skipped]
            robot_xy = np.asarray(self.env.robot.base_pose()[:2])
            self.target = min(left, key=lambda i: np.linalg.norm(task.chair_xy()[i] - robot_xy), default=None)
            self.tries, self.best = 0, np.inf
        return self.target

    def _track_progress(self, distance: float) -> None:
        if distance < self.best - 0.01:
            self.best, self.tries = distance, 0
            return
        self.tries += 1
        if self.tries > MAX_TRIES:
            self.skipped.add(self.target)

    # ------------------------------------------------------------------ geometry
    def _inward(self, chair: int) -> np.ndarray:
        """Unit vector along the gap normal, pointing under the table."""
        yaw = self.env.task.tucked_yaw[chair]
        return np.array([np.cos(yaw), np.sin(yaw)])

    def _stance(self, chair: int) -> tuple[np.ndarray, float]:
        task, inward = self.env.task, self._inward(chair)
        back = task.chairs[chair].backrest_point(PUSH_HEIGHT)[:2]
        along_line = task.tucked_xy[chair] + np.dot(back - task.tucked_xy[chair], inward) * inward
        return along_line - STANDOFF * inward, float(np.arctan2(inward[1], inward[0]))

    def _push(self, chair: int) -> np.ndarray | None:
        """Push along the gap normal, on the side of the backrest that turns the chair toward a
        heading that also removes its sideways offset (a slippery point contact drives the
        chair along its own heading, and an off-centre contact turns it)."""
        task, inward = self.env.task, self._inward(chair)
        offset = task.chair_xy()[chair] - task.tucked_xy[chair]
        remaining = -np.dot(offset, inward)
        sideways = float(np.dot(offset, [-inward[1], inward[0]]))
        heading_error = wrap(task.chairs[chair].pose()[2] - task.tucked_yaw[chair])
        wanted = -np.clip(np.arctan2(sideways, max(remaining, 0.15)), -MAX_STEER, MAX_STEER)
        contact = float(np.clip(STEER_GAIN * (heading_error - wanted), -MAX_CONTACT, MAX_CONTACT))
        length = min(0.25, max(remaining + OVERSHOOT, 0.05))
        geometry = task.chairs[chair].geometry
        point = task.chairs[chair].to_world((geometry.back_face_x, contact, PUSH_HEIGHT))
        return arm_action(self.env, point, np.array([*(length * inward), 0.0]))

def drive(env, target_xy: np.ndarray, target_yaw: float | None = None) -> np.ndarray:
    """Base action toward a world pose; turns on the spot first when the target is far off
    the heading (the local map is unknown behind the LiDAR's 220 deg, and the planner treats
    unknown as occupied)."""
    x, y, yaw = env.robot.base_pose()
    dx, dy = np.asarray(target_xy) - (x, y)
    bearing = float(np.arctan2(dy, dx))
    if np.hypot(dx, dy) > 0.3 and abs(wrap(bearing - yaw)) > MAX_DRIVE_BEARING:
        return base_action(env, (x, y), bearing)
    return base_action(env, target_xy, target_yaw)


# ---------------------------------------------------------------------- going round the table
def table_frame(table: Table, xy: np.ndarray) -> np.ndarray:
    """World xy -> (along the long side, across it) relative to the table centre."""
    d = np.asarray(xy, dtype=np.float64) - table.center
    c, s = np.cos(table.yaw), np.sin(table.yaw)
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])


def crosses_table(table: Table, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the segment a-b (table frame) passes over the table grown by TABLE_KEEPOUT."""
    half = np.array([0.5 * table.length, 0.5 * table.width]) + TABLE_KEEPOUT
    samples = a + np.linspace(0.0, 1.0, 50)[:, None] * (b - a)
    return bool(np.any(np.all(np.abs(samples) < half, axis=1)))


def next_waypoint(table: Table, robot_xy: np.ndarray, goal_xy: np.ndarray) -> np.ndarray | None:
    """First detour corner of the shortest corner path round the table; None when the goal
    is in sight."""
    a, b = table_frame(table, robot_xy), table_frame(table, goal_xy)
    if not crosses_table(table, a, b):
        return None
    hu, hv = 0.5 * table.length + CORNER_OFFSET[0], 0.5 * table.width + CORNER_OFFSET[1]
    corners = [np.array([su * hu, sv * hv]) for su in (-1, 1) for sv in (-1, 1)]
    nodes = [a, *corners, b]
    cost = {0: 0.0}
    first: dict[int, int] = {}
    todo = set(range(len(nodes)))
    while todo:  # Dijkstra on six nodes
        i = min((k for k in todo if k in cost), key=cost.get, default=None)
        if i is None:
            break
        todo.discard(i)
        for j in todo:
            if crosses_table(table, nodes[i], nodes[j]):
                continue
            new = cost[i] + float(np.linalg.norm(nodes[j] - nodes[i]))
            if new < cost.get(j, np.inf):
                cost[j], first[j] = new, (j if i == 0 else first[i])
    if len(nodes) - 1 not in first:
        return None
    corner = nodes[first[len(nodes) - 1]]
    c, s = np.cos(table.yaw), np.sin(table.yaw)
    return np.asarray(table.center) + np.array([c * corner[0] - s * corner[1], s * corner[0] + c * corner[1]])
