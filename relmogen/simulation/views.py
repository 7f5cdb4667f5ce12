"""Third-person images and GIF/MP4 writing."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import imageio.v3 as iio
import numpy as np
import pybullet as p

CHASE_DISTANCE = 2.2  # metres behind the robot
CHASE_HEIGHT = 4.5  # high enough to look over 2.5 m walls
OVERHEAD_HEIGHT = 6.5  # metres: from there the 2.5 m walls hide little of the floor around the robot
OVERHEAD_BACK = 1.0  # metres behind the robot, so its front is seen at a slant
FIELD_OF_VIEW_DEG = 60.0
VIDEO_SUFFIXES = (".gif", ".mp4")


@dataclass(frozen=True)
class ViewCamera:
    """A third-person camera: PyBullet's (column-major) view and projection matrices and the
    image size, enough to render it and to draw world points on its image."""

    view: tuple[float, ...]
    projection: tuple[float, ...]
    width: int
    height: int

    def project(self, points_world: np.ndarray) -> np.ndarray:
        """World points (N, 3) -> image positions (N, 2) as (x right, y down) in pixels."""
        points = np.atleast_2d(np.asarray(points_world, dtype=np.float64))
        homogeneous = np.concatenate([points, np.ones((len(points), 1))], axis=1)
        transform = np.reshape(self.projection, (4, 4)).T @ np.reshape(self.view, (4, 4)).T
        clip = homogeneous @ transform.T
        ndc = clip[:, :2] / clip[:, 3:4]
        return np.stack([(ndc[:, 0] + 1.0) / 2.0 * self.width, (1.0 - ndc[:, 1]) / 2.0 * self.height], axis=1)


def _camera(eye, target, up, width: int, height: int) -> ViewCamera:
    view = p.computeViewMatrix(list(eye), list(target), list(up))
    projection = p.computeProjectionMatrixFOV(fov=FIELD_OF_VIEW_DEG, aspect=width / height, nearVal=0.1,
                                              farVal=30.0)
    return ViewCamera(tuple(view), tuple(projection), width, height)


def chase_camera(base_pose: tuple[float, float, float], width: int, height: int) -> ViewCamera:
    """From above and behind the robot, looking a little ahead of it."""
    x, y, yaw = base_pose
    eye = [x - CHASE_DISTANCE * np.cos(yaw), y - CHASE_DISTANCE * np.sin(yaw), CHASE_HEIGHT]
    return _camera(eye, [x + 0.5 * np.cos(yaw), y + 0.5 * np.sin(yaw), 0.4], [0, 0, 1], width, height)


def overhead_camera(base_pose: tuple[float, float, float], width: int, height: int) -> ViewCamera:
    """High above the robot looking down, its forward direction up in the image: walls do not
    hide it, and a base subgoal up to 2 m away stays in the picture."""
    x, y, yaw = base_pose
    forward = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    eye = [x - OVERHEAD_BACK * forward[0], y - OVERHEAD_BACK * forward[1], OVERHEAD_HEIGHT]
    return _camera(eye, [x, y, 0.0], forward, width, height)


def render(client: int, camera: ViewCamera) -> np.ndarray:
    """The RGB image of ``camera`` (CPU renderer)."""
    _, _, rgba, _, _ = p.getCameraImage(
        camera.width, camera.height, list(camera.view), list(camera.projection), renderer=p.ER_TINY_RENDERER,
        flags=p.ER_NO_SEGMENTATION_MASK, physicsClientId=client,
    )
    return np.asarray(rgba, dtype=np.uint8).reshape(camera.height, camera.width, 4)[..., :3]


def third_person_view(client: int, base_pose: tuple[float, float, float], width: int, height: int) -> np.ndarray:
    """An RGB image from above and behind the robot (CPU renderer)."""
    return render(client, chase_camera(base_pose, width, height))


def check_animation_path(path: str | Path) -> Path:
    """``path`` when its suffix is one ``write_animation`` writes (``.gif`` or ``.mp4``)."""
    path = Path(path)
    if path.suffix.lower() not in VIDEO_SUFFIXES:
        raise ValueError(f"cannot write a video to {path}: give a file name ending in "
                         f"{' or '.join(VIDEO_SUFFIXES)}")
    return path


def write_animation(frames: Iterable[np.ndarray], path: str | Path, fps: int = 10) -> Path:
    """Write frames to a GIF or MP4 (by suffix; MP4 through imageio's ffmpeg plugin) and return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    frames = np.stack(list(frames))
    if path.suffix.lower() == ".gif":
        iio.imwrite(path, frames, duration=int(1000 / fps), loop=0)
    else:
        iio.imwrite(path, frames, fps=fps, plugin="FFMPEG")
    return path
