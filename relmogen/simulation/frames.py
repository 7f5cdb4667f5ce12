"""Planar frame changes between the world and a pose ``(x, y, yaw)`` (robot, box, map)."""

from __future__ import annotations

from typing import Sequence

import numpy as np


def to_local(points_xy: np.ndarray, pose: Sequence[float]) -> np.ndarray:
    """World points (..., 2) -> the frame of ``pose``."""
    x, y, yaw = pose
    d = np.asarray(points_xy, dtype=np.float64)[..., :2] - (x, y)
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * d[..., 0] + s * d[..., 1], -s * d[..., 0] + c * d[..., 1]], axis=-1)


def to_world(points_xy: np.ndarray, pose: Sequence[float]) -> np.ndarray:
    """Points (..., 2) in the frame of ``pose`` -> the world."""
    x, y, yaw = pose
    p = np.asarray(points_xy, dtype=np.float64)
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([x + c * p[..., 0] - s * p[..., 1], y + s * p[..., 0] + c * p[..., 1]], axis=-1)


def heading_axes(yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """Unit vector along ``yaw`` and the one 90 deg to its left."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([c, s]), np.array([-s, c])


class FacesYaw:
    """Mixin for something placed facing ``yaw``: ``normal`` points along it, ``along`` 90 deg to its left."""

    yaw: float

    @property
    def normal(self) -> np.ndarray:
        return heading_axes(self.yaw)[0]

    @property
    def along(self) -> np.ndarray:
        return heading_axes(self.yaw)[1]
