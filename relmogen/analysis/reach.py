"""Where arm subgoals can succeed: plans by distance, the reach mask against IK, button presses.

``reach_samples``: random camera pixels with depth in task states, each point handed to the
motion generator's arm (IK, collision checking as asked, joint-space plan, no push) whatever the
robot's ``arm_reach`` mask; counted per band of distance from the first arm joint. The robot's
``arm_reach`` is the edge beyond which no plan was found.

``reach_mask_cells``: arm cells the sphere mask allows (``env.reach_mask=sphere``), each solved
by the arm's IK without collisions, and whether the robot's measured reachability map
(``env.reach_mask=measured``) holds the point.

``button_presses``: the robot stands in front of ButtonDoorNav's button, facing it; every push
direction of the SGP-D arm cells around the button's pixel is executed from the same reset.

    relmogen analyse reach [--robot fetch] [--tasks T ...] [--episodes 4] [--per-state 20] [--base-moves 0] [--json]
    relmogen analyse reach-mask --task T [--episodes 8] [--json]
    relmogen analyse button-presses [--episodes 4] [--stand-off 0.65] [--radius 1] [--json]
"""

from __future__ import annotations

import math

import numpy as np

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import PUSH_BINS, YAW_BINS, RewardAccumulator

BANDS = ((0.0, 0.6), (0.6, 0.8), (0.8, 1.0), (1.0, 1.2), (1.2, 1.3), (1.3, 1.4), (1.4, 1.6), (1.6, math.inf))
REACH_TASKS = ("TabletopReachM", "PushDoorNav", "ArrangeKitchenMM")


def no_ticks(_dt: float) -> None:
    """A motion-generator tick that records nothing."""


def reach_samples(robot: str = "fetch", task: str = "PushDoorNav", episodes: int = 4, per_state: int = 20,
                  seed: int = 2000, image_size: int = 64, arm_collision: bool = True, base_moves: int = 0,
                  sample_seed: int = 0) -> list[dict]:
    """One row per sampled pixel: distance from the arm's base, height, plan found, reason. In each
    episode (seeds ``seed``, ``seed`` + 1, ...) ``base_moves`` random base subgoals come first; the
    world is restored before each sample."""
    env = RelmogenEnv(task=task, control="subgoal-r", robot=robot, image_size=image_size, arm_collision=arm_collision)
    rng, rows = np.random.default_rng(sample_seed), []
    try:
        for episode in range(episodes):
            env.reset(seed=seed + episode)
            env.action_space.seed(seed + episode)
            for _ in range(base_moves):
                action = env.action_space.sample()
                action[0] = 1.0  # a base subgoal
                env.step(action)
            frame, state = env.last_frame, env.world.save_state()
            rows_with_depth, cols_with_depth = np.nonzero(frame.depth > 0)
            for _ in range(per_state if len(rows_with_depth) else 0):
                env.world.restore_state(state)
                k = int(rng.integers(len(rows_with_depth)))
                point = env.camera.pixel_to_world(frame, int(cols_with_depth[k]), int(rows_with_depth[k]))
                distance = float(np.linalg.norm(point - env.robot.arm_base_position()))
                result = env.control.mg.reach_and_push(point, np.zeros(3), env.np_random, no_ticks)
                rows.append({"task": task, "episode": seed + episode, "distance": round(distance, 3),
                             "height": round(float(point[2]), 3), "plan_found": bool(result.success),
                             "reason": result.reason})
            env.world.restore_state(state)
            env.world.remove_state(state)
    finally:
        env.close()
    return rows


def by_band(rows: list[dict], bands=BANDS) -> list[dict]:
    """Samples and plans per distance band, then all of them with the farthest planned distance."""
    table = []
    for low, high in bands:
        band = [r for r in rows if low <= r["distance"] < high]
        table.append({"band_m": f"{low}-{high if math.isfinite(high) else ''}", "samples": len(band),
                      "planned": sum(r["plan_found"] for r in band)})
    planned = [r["distance"] for r in rows if r["plan_found"]]
    table.append({"band_m": "all", "samples": len(rows), "planned": len(planned),
                  "farthest_planned_m": max(planned) if planned else None})
    return table


def reach_mask_cells(task: str = "ArrangeKitchenMM", episodes: int = 8, cells_per_state: int = 40,
                     base_moves: int = 2, seed: int = 100_000, push_frame: str = "surface",
                     ik_attempts: int = 50, episode_steps: int | None = None) -> list[dict]:
    """One row per sampled sphere-allowed arm cell (relmogen-d's ``cpu`` environment, checking
    off): horizontal distance and height of its point, whether the measured map holds it, whether
    IK solves it. States: each episode's start and the states after ``base_moves`` random base
    subgoals."""
    from relmogen.experiments.config import resolve_config
    from relmogen.experiments.environments import env_kwargs
    from relmogen.robots.reachability import load_reachability

    config = resolve_config(task, "relmogen-d", overrides=[f"env.push_frame={push_frame}"])
    kwargs = env_kwargs(config, arm_collision=False)
    if episode_steps is not None:
        kwargs["episode_steps"] = episode_steps
    env = RelmogenEnv(**kwargs)
    reach, rng, rows = load_reachability(env.robot.spec), np.random.default_rng(0), []
    control = env.control
    config_arm = control.mg.arm.config
    try:
        for episode in range(episodes):
            _, info = env.reset(seed=seed + episode)
            for move in range(base_moves + 1):
                pose = env.robot.base_pose()
                cells = np.argwhere(info["arm_mask"])
                for i, j in cells[rng.permutation(len(cells))[:cells_per_state]]:
                    row, col = control.cell_pixel(int(i), int(j))
                    point = env.camera.pixel_to_world(env.last_frame, col, row)
                    solved = control.mg.arm.ik_solver.solve(point, rng, config_arm.ik_iterations, ik_attempts,
                                                            config_arm.ik_tolerance).config is not None
                    rows.append({"distance": round(float(np.linalg.norm(point[:2] - pose[:2])), 3),
                                 "height": round(float(point[2]), 3),
                                 "in_map": bool(reach.contains_world(point[None], pose)[0]), "ik_solved": solved})
                if move == base_moves or not info["base_mask"].any():
                    break
                i, j = np.argwhere(info["base_mask"])[rng.integers(info["base_mask"].sum())]
                _, _, terminated, truncated, info = env.step(control.encode("base", int(rng.integers(YAW_BINS)),
                                                                            int(i), int(j)))
                if terminated or truncated:
                    break
    finally:
        env.close()
    return rows


def reach_mask_summary(rows: list[dict]) -> dict:
    """Of the sampled cells: IK solved; of the unsolvable ones, the share the measured map leaves
    out; of the solvable ones, the share it leaves out; IK success per 0.2 m band."""
    solved = [r for r in rows if r["ik_solved"]]
    unsolved = [r for r in rows if not r["ik_solved"]]
    bands = {}
    for low in np.arange(0.0, 1.4, 0.2):
        band = [r for r in rows if low <= r["distance"] < low + 0.2]
        if band:
            bands[f"{low:.1f}-{low + 0.2:.1f}"] = {"cells": len(band),
                                                    "ik_solved": round(float(np.mean([r["ik_solved"] for r in band])), 3)}
    return {"cells": len(rows), "ik_solved": round(len(solved) / max(len(rows), 1), 3),
            "unsolvable_left_out": round(sum(not r["in_map"] for r in unsolved) / len(unsolved), 3) if unsolved else None,
            "solvable_left_out": round(sum(not r["in_map"] for r in solved) / len(solved), 3) if solved else None,
            "by_distance": bands}


def button_presses(episodes: int = 4, stand_off: float = 0.65, radius: int = 1, seed: int = 0, image_size: int = 64,
                   qmap_size: int | None = None, bins: tuple[int, ...] = tuple(range(PUSH_BINS))) -> list[dict]:
    """One row per SGP-D arm cell within ``radius`` cells of the button's pixel (base push frame,
    arm collision checking off): which push ``bins`` pressed the button. Every push starts from
    the same state: the episode reset, the robot ``stand_off`` m in front of the button facing it."""
    env = RelmogenEnv(task="ButtonDoorNav", control="subgoal-d", image_size=image_size, qmap_size=qmap_size,
                      arm_collision=False)
    control, rows = env.control, []

    def stand(episode: int):
        env.reset(seed=seed + episode)
        button = env.task.button
        xy = button.face_xy + stand_off * button.out_normal
        env.robot.set_base_pose(xy[0], xy[1], math.atan2(-button.out_normal[1], -button.out_normal[0]))
        return env.camera.capture(*env.robot.camera_pose())

    try:
        for episode in range(episodes):
            frame = stand(episode)
            local = frame.rotation.T @ (np.asarray(env.task.button.face_centre()) - frame.position)
            if local[0] <= 0.0:
                continue
            u, v, _ = env.camera.intrinsics.project(local)
            height, width = frame.depth.shape
            if not (0 <= round(v) < height and 0 <= round(u) < width):
                continue
            centre = control.pixel_cell(int(round(v)), int(round(u)))
            for di in range(-radius, radius + 1):
                for dj in range(-radius, radius + 1):
                    i, j = centre[0] + di, centre[1] + dj
                    if not (0 <= i < control.q and 0 <= j < control.q):
                        continue
                    pressing = []
                    for bin_ in bins:
                        frame = stand(episode)
                        row, col = control.cell_pixel(i, j)
                        if not frame.has_point(row, col):
                            continue
                        point = env.camera.pixel_to_world(frame, col, row)
                        push_base = control.push_vector(bin_, i, j)
                        yaw = env.robot.base_pose()[2]
                        push = np.array([np.cos(yaw) * push_base[0] - np.sin(yaw) * push_base[1],
                                         np.sin(yaw) * push_base[0] + np.cos(yaw) * push_base[1], 0.0])
                        env.control.mg.reach_and_push(point, push, env.np_random, RewardAccumulator(env).tick)
                        if env.task.button_pressed():
                            pressing.append(bin_)
                    rows.append({"episode": seed + episode, "cell": [i, j], "button_cell": (i, j) == tuple(centre),
                                 "bins_tried": len(bins), "bins_pressing": pressing})
    finally:
        env.close()
    return rows
