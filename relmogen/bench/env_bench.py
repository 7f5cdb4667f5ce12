"""``relmogen bench env``: what one environment step costs against the PyBullet floor.

``floor_ms`` is the bare PyBullet work a joint-velocity step cannot avoid, measured in the
same world: 4 physics steps, one camera render at the same pose and resolution, one LiDAR
ray batch. ``joint_step_ms`` is a full ``env.step`` including every observation. Both are
medians over interleaved samples, so machine noise hits them alike.
"""

from __future__ import annotations

import time

import numpy as np
import pybullet as p

from relmogen.envs.relmogen_env import RelmogenEnv


def _timed(fn) -> float:
    start = time.perf_counter()
    fn()
    return (time.perf_counter() - start) * 1000.0


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


def bench_env(task: str = "PointNav", samples: int = 200, image_size: int = 128, seed: int = 0) -> dict:
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
    return {
        "task": task,
        "image_size": image_size,
        "samples": samples,
        "joint_step_ms": round(joint, 3),
        "floor_ms": round(floor, 3),
        "ratio": round(joint / floor, 3),
        "reset_ms": round(float(np.median(resets)), 3),
    }
