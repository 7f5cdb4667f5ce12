"""Shared by the door task tests."""

import numpy as np


def drive_forward_until_done(env, steps: int = 30) -> tuple[bool, dict]:
    """Full speed ahead on both wheels; returns (terminated, last info)."""
    forward = np.zeros(env.action_space.shape, dtype=np.float32)
    forward[:2] = 1.0
    terminated, info = False, {}
    for _ in range(steps):
        _, _, terminated, truncated, info = env.step(forward)
        if terminated or truncated:
            break
    return terminated, info
