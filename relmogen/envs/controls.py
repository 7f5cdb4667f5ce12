"""Action spaces: what one environment step means.

``joint``: 10-D normalised joint velocities (2 wheels, torso, 7 arm joints) held for 0.1 s,
as the SAC/OAC baselines use (paper Section IV-B). The subgoal controls (``subgoal-r``,
``subgoal-d``, ``subgoal_controls.py``) execute one subgoal through the motion generator per
step; ``control_registry.py`` builds a control by name.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

if TYPE_CHECKING:
    from relmogen.envs.relmogen_env import RelmogenEnv


@dataclass
class StepOutcome:
    reward: float
    termination: str | None
    reward_terms: dict[str, float] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)


def validate_action(action, shape: tuple[int, ...]) -> np.ndarray:
    """A float64 copy of ``action``; ValueError naming the problem if malformed."""
    try:
        arr = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"action must be numeric with shape {shape}, got {action!r}") from exc
    if arr.shape != shape:
        raise ValueError(f"action must have shape {shape}, got shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        kinds = sorted({"NaN" if np.isnan(v) else "infinite" for v in arr[bad]})
        raise ValueError(f"action has {' and '.join(kinds)} values at indices {np.flatnonzero(bad).tolist()}")
    return arr


class Control:
    """What one environment step means. Subclasses set ``action_space`` and
    ``episode_steps`` and implement ``step``; the extras default to nothing."""

    name: str

    def reset(self) -> None:
        pass

    def extra_observation(self) -> dict[str, np.ndarray]:
        return {}

    def extra_observation_space(self) -> dict[str, spaces.Space]:
        return {}

    def extra_info(self) -> dict[str, np.ndarray]:
        return {}


class JointVelocityControl(Control):
    """Normalised joint velocities in [-1, 1] (out-of-range values are clipped)."""

    name = "joint"

    def __init__(self, env: RelmogenEnv):
        self.env = env
        self.action_space = spaces.Box(-1.0, 1.0, (len(env.robot.controlled_joint_indices),), np.float32)
        self.episode_steps = env.task.joint_steps

    def step(self, action) -> StepOutcome:
        command = np.clip(validate_action(action, self.action_space.shape), -1.0, 1.0)
        self.env.robot.apply_normalized_velocity(command)
        reward, terms, termination = self.env.simulate_control_step()
        info = {}
        if termination == "collision":
            info["collisions"] = [c.describe(self.env.world.client) for c in self.env.collisions()]
        return StepOutcome(reward, termination, terms, info)
