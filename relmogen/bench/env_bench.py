"""``relmogen bench env``: what one environment step costs against the PyBullet floor.

``floor_ms`` is the bare PyBullet work a joint-velocity step cannot avoid, measured in the
same world: 4 physics steps, one camera render at the same pose and resolution, one LiDAR
ray batch. ``joint_step_ms`` is a full ``env.step`` including every observation. Both are
medians over interleaved samples, so machine noise hits them alike. Every ``*_ms`` is CPU time of
the benchmarking process (``time.process_time``), not wall time: runs sharing the machine slow
the wall clock, not the figures.

The lifted (``subgoal-r``) steps are measured in the same run, each a full ``env.step``
including the observations at the same image size:

* ``subgoal_base_step_ms``: PointNav base subgoals, two thirds short forward targets (0.5-1 m,
  within 45 deg of straight ahead, goal footprint free on the current local map), one third
  turns in place;
* ``subgoal_arm_step_ms``: TabletopReachM arm subgoals (collision checking on) on pixels that
  see the table top within the arm's reach, with a 0.1-0.2 m forward push, with the default
  ``arm_collision_backend``; ``arm_by_backend`` has the arm figures of every backend (the same
  subgoals, one after the other in the same process).

Headline figures are medians over the steps whose plan was found and executed; ``*_all_ms``
are medians over every attempt and ``*_plan_rate`` the fraction of attempts with a plan;
``base_step_vs_floor`` / ``arm_step_vs_floor`` divide the headline figures by ``floor_ms``.
"""

from __future__ import annotations

import time

import numpy as np
import pybullet as p

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import BASE_ANGLE_RANGE, PUSH_MAX
from relmogen.motion_generation.arm import COLLISION_BACKENDS, ArmConfig
from relmogen.motion_generation.base_planner import FootprintChecker

FORWARD_SECTOR = np.deg2rad(45.0)
TABLE_PIXEL_STRIDE = 4


def _timed(fn) -> float:
    """CPU milliseconds of this process (PyBullet DIRECT and its CPU renderer run in it), so the
    figures hold on a machine that other jobs share; on an idle one they equal wall time."""
    start = time.process_time()
    fn()
    return (time.process_time() - start) * 1000.0


def _floor_step(env: RelmogenEnv):
    client = env.world.client
    cam = env.camera.intrinsics
    position, rotation = env.robot.camera_pose()
    view = p.computeViewMatrix(position, position + rotation[:, 0], rotation[:, 2])
    projection = env.camera._projection
    lidar_position, _ = env.robot.lidar_pose()
    yaw = env.robot.base_pose()[2]
    dirs = env.lidar._unit @ np.array([[np.cos(yaw), -np.sin(yaw), 0], [np.sin(yaw), np.cos(yaw), 0], [0, 0, 1]]).T
    starts = (np.asarray(lidar_position) + env.lidar.min_range * dirs).tolist()
    ends = (np.asarray(lidar_position) + env.lidar.max_range * dirs).tolist()

    def run():
        for _ in range(env.control_steps_per_action):
            p.stepSimulation(physicsClientId=client)
        p.getCameraImage(cam.width, cam.height, view, projection, renderer=p.ER_TINY_RENDERER,
                         flags=p.ER_NO_SEGMENTATION_MASK, physicsClientId=client)
        p.rayTestBatch(starts, ends, physicsClientId=client)

    return run


def bench_env(task: str = "PointNav", samples: int = 200, image_size: int = 128, seed: int = 0,
              subgoal_samples: int = 40) -> dict:
    env = RelmogenEnv(task=task, control="joint", image_size=image_size)
    rng = np.random.default_rng(seed)
    resets = [_timed(lambda: env.reset(seed=seed + i)) for i in range(20)]
    env.reset(seed=seed)
    steps, floors = [], []
    for _ in range(samples):
        action = rng.uniform(-0.3, 0.3, env.action_space.shape).astype(np.float32)
        floors.append(_timed(_floor_step(env)))
        result = {}
        steps.append(_timed(lambda: result.update(out=env.step(action))))
        _, _, terminated, truncated, _ = result["out"]
        if terminated or truncated:
            env.reset(seed=int(rng.integers(1 << 30)))
    env.close()
    joint, floor = float(np.median(steps)), float(np.median(floors))
    subgoals = bench_subgoal_steps(subgoal_samples, image_size, seed, floor) if subgoal_samples > 0 else {}
    return {
        "task": task,
        "image_size": image_size,
        "samples": samples,
        "joint_step_ms": round(joint, 3),
        "floor_ms": round(floor, 3),
        "ratio": round(joint / floor, 3),
        "reset_ms": round(float(np.median(resets)), 3),
        "reset_ms_by_task": reset_medians(image_size, seed),
        **subgoals,
    }


def reset_medians(image_size: int, seed: int, resets: int = 15) -> dict[str, float]:
    """Median ``env.reset`` (re-randomise in place, first observation included) per task."""
    from relmogen.tasks import TASKS

    medians = {}
    for name in sorted(TASKS):
        env = RelmogenEnv(task=name, control="joint", image_size=image_size)
        env.reset(seed=seed)  # the first reset may build caches
        medians[name] = round(float(np.median([_timed(lambda: env.reset(seed=seed + i)) for i in range(resets)])), 3)
        env.close()
    return medians


# ----------------------------------------------------------------------------- lifted steps


def _base_action(angle: float, distance: float, yaw_change: float) -> np.ndarray:
    """subgoal-r action for a robot-frame polar target (see ``subgoal_controls``)."""
    action = np.zeros(8, dtype=np.float32)
    action[:4] = (1.0, angle / BASE_ANGLE_RANGE, distance - 1.0, yaw_change / np.pi)
    return np.clip(action, -1.0, 1.0)


def forward_or_turn_action(env: RelmogenEnv, rng: np.random.Generator, step: int) -> np.ndarray:
    """A short forward target whose goal footprint is free on the local map (two steps in
    three), otherwise a turn in place."""
    if step % 3 != 2:
        checker = FootprintChecker(env.control.mg.local_map(), env.robot.spec.base_radius)
        for _ in range(20):
            angle, distance = rng.uniform(-FORWARD_SECTOR, FORWARD_SECTOR), rng.uniform(0.5, 1.0)
            goal = np.array([distance * np.cos(angle), distance * np.sin(angle), angle])
            if not checker.footprint_hits_obstacle(goal):
                return _base_action(angle, distance, angle)
    return _base_action(0.0, 0.0, rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 1.0) * np.pi)


def table_pixels(env: RelmogenEnv) -> list[tuple[int, int]]:
    """(row, col) pixels of the last frame that see the reach table top within arm's reach."""
    frame, table = env.last_frame, env.scene.reach_table
    x, y, yaw = env.robot.base_pose()
    forward, left = np.array([np.cos(yaw), np.sin(yaw)]), np.array([-np.sin(yaw), np.cos(yaw)])
    pixels = []
    for row in range(0, frame.depth.shape[0], TABLE_PIXEL_STRIDE):
        for col in range(0, frame.depth.shape[1], TABLE_PIXEL_STRIDE):
            if not frame.has_point(row, col):
                continue
            point = env.camera.pixel_to_world(frame, col, row)
            offset = point[:2] - (x, y)
            if (abs(point[2] - table.height) < 0.02 and table.footprint.contains(point[:2], margin=0.05)
                    and 0.45 <= offset @ forward <= 0.95 and abs(offset @ left) <= 0.4):
                pixels.append((row, col))
    return pixels


def table_reach_action(env: RelmogenEnv, rng: np.random.Generator, step: int) -> np.ndarray:
    """An arm subgoal on a table-top pixel (any pixel if none is visible), pushing forward."""
    height, width = env.last_frame.depth.shape
    pixels = table_pixels(env) or [(int(rng.integers(height)), int(rng.integers(width)))]
    row, col = pixels[rng.integers(len(pixels))]
    action = np.zeros(8, dtype=np.float32)
    action[0] = -1.0
    action[4:6] = ((row + 0.5) / height * 2.0 - 1.0, (col + 0.5) / width * 2.0 - 1.0)
    action[6:8] = (rng.uniform(0.1, 0.2) / PUSH_MAX, rng.uniform(-0.05, 0.05) / PUSH_MAX)
    return action


def time_subgoal_steps(env: RelmogenEnv, choose_action, samples: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """CPU time (ms) of ``samples`` lifted steps and whether each found and executed a plan."""
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    times, found = [], []
    for step in range(samples):
        action = choose_action(env, rng, step)
        result = {}
        times.append(_timed(lambda: result.update(out=env.step(action))))
        _, _, terminated, truncated, info = result["out"]
        found.append(bool(info["plan_found"]))
        if terminated or truncated:
            env.reset(seed=int(rng.integers(1 << 30)))
    return np.array(times), np.array(found)


def _subgoal_figures(kind: str, times: np.ndarray, found: np.ndarray, floor: float) -> dict:
    executed = float(np.median(times[found])) if found.any() else None
    return {
        f"subgoal_{kind}_step_ms": None if executed is None else round(executed, 3),
        f"subgoal_{kind}_step_all_ms": round(float(np.median(times)), 3),
        f"subgoal_{kind}_plan_rate": round(float(found.mean()), 3),
        f"{kind}_step_vs_floor": None if executed is None else round(executed / floor, 3),
    }


def bench_subgoal_steps(samples: int, image_size: int, seed: int, floor: float) -> dict:
    """Lifted base steps (PointNav) and arm steps (TabletopReachM), both ``subgoal-r``; the arm's
    with each collision backend (``arm_by_backend``), the headline figures with the default one."""
    figures = {"subgoal_samples": samples, "arm_collision_backend": ArmConfig.collision_backend}
    figures.update(_subgoal_run("base", "PointNav", forward_or_turn_action, samples, image_size, seed, floor))
    by_backend = {backend: _subgoal_run("arm", "TabletopReachM", table_reach_action, samples, image_size, seed, floor,
                                        arm_collision_backend=backend) for backend in COLLISION_BACKENDS}
    figures.update(by_backend[ArmConfig.collision_backend])
    figures["arm_by_backend"] = by_backend
    return figures


def _subgoal_run(kind: str, task: str, choose_action, samples: int, image_size: int, seed: int, floor: float,
                 **control_options) -> dict:
    env = RelmogenEnv(task=task, control="subgoal-r", image_size=image_size, arm_collision=True, **control_options)
    try:
        return _subgoal_figures(kind, *time_subgoal_steps(env, choose_action, samples, seed), floor)
    finally:
        env.close()
