"""Third-person images and GIF/MP4 writing."""

from __future__ import annotations

from pathlib import Path
from typing import Iterable

import imageio.v3 as iio
import numpy as np
import pybullet as p

CHASE_DISTANCE = 2.2  # metres behind the robot
CHASE_HEIGHT = 4.5  # high enough to look over 2.5 m walls


def third_person_view(client: int, base_pose: tuple[float, float, float], width: int, height: int) -> np.ndarray:
    """An RGB image from above and behind the robot (CPU renderer)."""
    x, y, yaw = base_pose
    eye = [x - CHASE_DISTANCE * np.cos(yaw), y - CHASE_DISTANCE * np.sin(yaw), CHASE_HEIGHT]
    view = p.computeViewMatrix(eye, [x + 0.5 * np.cos(yaw), y + 0.5 * np.sin(yaw), 0.4], [0, 0, 1])
    projection = p.computeProjectionMatrixFOV(fov=60.0, aspect=width / height, nearVal=0.1, farVal=30.0)
    _, _, rgba, _, _ = p.getCameraImage(
        width, height, view, projection, renderer=p.ER_TINY_RENDERER,
        flags=p.ER_NO_SEGMENTATION_MASK, physicsClientId=client,
    )
    return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[..., :3]


def write_animation(frames: Iterable[np.ndarray], path: str | Path, fps: int = 10) -> Path:
    """Write frames to a GIF or MP4 (by suffix) and return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    frames = np.stack(list(frames))
    if path.suffix.lower() == ".gif":
        iio.imwrite(path, frames, duration=int(1000 / fps), loop=0)
    else:
        iio.imwrite(path, frames, fps=fps)
    return path
