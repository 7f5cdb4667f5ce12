"""Top-down maps of a whole scene for figures (``relmogen viz subgoals``, ``relmogen viz exploration``).

The background is the scene's static floor plan (``scene.trav_map``: free floor light, walls and
furniture dark), in world metres with x to the right and y up. On it: the task's door, drawn
closed across its doorway, when it has one (``PushDoorNav``, ``ButtonDoorNav``: ``task.door``),
and per episode the task's goal (navigation tasks).
"""

from __future__ import annotations

import numpy as np

DOOR_COLOUR = "saddlebrown"
GOAL_COLOUR = "limegreen"
MAP_MARGIN_M = 1.5  # around the points drawn when a map is zoomed to them
MIN_VIEW_M = 6.0  # a zoomed map shows at least this much of the scene along each axis


def task_door(task):
    """The task's hinged door (``HingedDoor``), or None when it has none."""
    return getattr(task, "door", None)


def task_goal(task) -> list[float] | None:
    """The episode's goal xy of a navigation task, or None."""
    goal = getattr(task, "goal_xy", None)
    return None if goal is None else [float(v) for v in np.asarray(goal)[:2]]


def door_distances(task, xy) -> dict[str, float]:
    """How far the base centre ``xy`` is from the task's door, or {} when it has none:
    ``door_distance``, metres from the doorway's closed-door line (the segment across the
    opening through its centre), and ``door_offset``, the signed distance along the doorway
    normal (negative on the side the door is pushed from, ``doorway.regions[0]``; positive in
    the room it swings into, ``doorway.regions[1]``)."""
    door = task_door(task)
    if door is None:
        return {}
    doorway = door.doorway
    offset = np.asarray(xy, dtype=float)[:2] - np.asarray(doorway.center, dtype=float)
    along = float(np.clip(offset @ doorway.along, -0.5 * doorway.width, 0.5 * doorway.width))
    normal = float(offset @ doorway.normal)
    return {"door_distance": float(np.hypot(offset @ doorway.along - along, normal)), "door_offset": normal}


def doorway_segment(doorway) -> np.ndarray:
    """(2, 2) world xy of the ends of the line across the doorway."""
    centre, half = np.asarray(doorway.center, dtype=float), 0.5 * doorway.width * doorway.along
    return np.stack([centre - half, centre + half])


def draw_floor_plan(axis, env) -> None:
    """The static floor plan, and the task's door (closed, across its doorway) if it has one."""
    trav = env.scene.trav_map
    rows, cols = trav.free.shape
    x0, y0 = trav.origin
    extent = (x0, x0 + cols * trav.resolution, y0, y0 + rows * trav.resolution)
    axis.imshow(np.where(trav.free, 0.92, 0.35), cmap="gray", vmin=0.0, vmax=1.0, origin="lower",
                extent=extent, interpolation="nearest")
    door = task_door(env.task)
    if door is not None:
        ends = doorway_segment(door.doorway)
        axis.plot(ends[:, 0], ends[:, 1], color=DOOR_COLOUR, lw=3.0, solid_capstyle="butt", label="door (closed)",
                  zorder=3)
    axis.set_aspect("equal")
    axis.set_xlabel("x (m)", fontsize=8)
    axis.set_ylabel("y (m)", fontsize=8)
    axis.tick_params(labelsize=7)


def draw_goals(axis, goals) -> None:
    goals = np.array([g for g in goals if g is not None], dtype=float).reshape(-1, 2)
    if len(goals):
        axis.scatter(goals[:, 0], goals[:, 1], marker="*", s=110, color=GOAL_COLOUR, edgecolors="black",
                     linewidths=0.6, label="goal", zorder=5)


def zoom_to(axis, env, points, margin: float = MAP_MARGIN_M, min_view: float = MIN_VIEW_M) -> None:
    """Limit the view to the points (N, 2) plus ``margin``, at least ``min_view`` metres wide and
    high, within the scene; the whole scene when there are none."""
    bounds = env.scene.bounds
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    points = points[np.isfinite(points).all(axis=1)]
    if not len(points):
        axis.set_xlim(bounds.xmin, bounds.xmax)
        axis.set_ylim(bounds.ymin, bounds.ymax)
        return
    low, high = points.min(axis=0) - margin, points.max(axis=0) + margin
    grow = np.maximum(min_view - (high - low), 0.0) / 2
    low, high = low - grow, high + grow
    axis.set_xlim(max(low[0], bounds.xmin), min(high[0], bounds.xmax))
    axis.set_ylim(max(low[1], bounds.ymin), min(high[1], bounds.ymax))
