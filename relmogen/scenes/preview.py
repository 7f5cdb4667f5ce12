"""Render scenes with PyBullet's TinyRenderer (no GL) for a visual check and timings.

    python -m relmogen.scenes.preview [--out /tmp]

Writes scene_<name>_top.png (top-down) and scene_<name>_view.png (third person) and prints
the build time and the time of a 128x128 robot-height camera image.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
import pybullet as p

from relmogen.scenes.scene import Scene, available_scenes, make_scene


def render(client: int, eye, target, size: int = 128, fov: float = 90.0, far: float = 30.0,
           up=(0, 0, 1)) -> np.ndarray:
    view = p.computeViewMatrix(eye, target, up, physicsClientId=client)
    proj = p.computeProjectionMatrixFOV(fov, 1.0, 0.05, far, physicsClientId=client)
    _, _, rgb, _, _ = p.getCameraImage(size, size, view, proj, renderer=p.ER_TINY_RENDERER,
                                       physicsClientId=client)
    return np.reshape(rgb, (size, size, 4))[:, :, :3].astype(np.uint8)


def top_down(scene: Scene, size: int = 512) -> np.ndarray:
    cx, cy = scene.bounds.center
    half = 0.5 * max(scene.bounds.size) + 0.5
    height = 40.0
    fov = math.degrees(2 * math.atan(half / height))
    return render(scene.client, (cx, cy, height), (cx, cy, 0), size, fov, far=60.0, up=(0, 1, 0))


def third_person(scene: Scene, size: int = 384) -> np.ndarray:
    b = scene.bounds
    eye = (b.xmin - 2.0, b.ymin - 3.0, 9.0)
    return render(scene.client, eye, (*b.center, 0.0), size, fov=70.0)


def robot_view(scene: Scene) -> tuple[np.ndarray, float]:
    """128x128, 90 deg image from a 1.2 m high camera looking along the start region."""
    rng = np.random.default_rng(0)
    xy = scene.sample_free_point(rng, scene.start_region)
    eye = (xy[0], xy[1], 1.2)
    target = (xy[0] + 3.0, xy[1] + 0.5, 0.8)
    t = time.perf_counter()
    for _ in range(20):
        img = render(scene.client, eye, target, 128, 90.0, far=3.0)
    return img, (time.perf_counter() - t) / 20


def main() -> None:
    import imageio.v3 as iio

    parser = argparse.ArgumentParser()
    parser.add_argument("--out", default="/tmp")
    args = parser.parse_args()
    client = p.connect(p.DIRECT)
    for name in available_scenes():
        t = time.perf_counter()
        scene = make_scene(name, client, seed=0)
        build = time.perf_counter() - t
        iio.imwrite(Path(args.out) / f"scene_{name}_top.png", top_down(scene))
        iio.imwrite(Path(args.out) / f"scene_{name}_view.png", third_person(scene))
        img, dt = robot_view(scene)
        iio.imwrite(Path(args.out) / f"scene_{name}_robot.png", img)
        print(f"{name}: build {build * 1e3:.1f} ms, 128x128 robot-height image {dt * 1e3:.2f} ms, "
              f"{len(scene.static_body_ids)} static bodies")
        scene.remove()
    p.disconnect(client)


if __name__ == "__main__":
    main()
