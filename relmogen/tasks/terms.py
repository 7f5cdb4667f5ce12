"""Reward terms and episode metrics shared by the tasks.

A task is a list of small reward terms. Each term is reset at the start of an episode and
then called once per low-level control step (0.1 s); the environment sums the returned values.
Subgoal controls add up the low-level rewards accrued while one subgoal executes. A
``StateReward`` (a penalty on the current state, not on progress) is charged once per
decision instead, so a long motion is not punished for its duration and a no-op subgoal
costs what standing still for one decision costs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

Potential = Callable[[], float]


@dataclass
class PotentialReward:
    per_decision = False

    """``weight * (previous - current)`` of a potential: positive when the potential falls.

    Used for geodesic distance to the goal (weight 1), door opening (potential = -angle),
    closing progress (potential = summed openings) and chair tucking (distance to tucked).
    """

    name: str
    potential: Potential
    weight: float = 1.0
    _previous: float = field(default=0.0, init=False, repr=False)

    def reset(self) -> None:
        self._previous = self.potential()

    def __call__(self) -> float:
        current = self.potential()
        reward = self.weight * (self._previous - current)
        self._previous = current
        return float(reward) if np.isfinite(reward) else 0.0


@dataclass
class StateReward:
    """``weight * value()`` every step, e.g. ``-1 x`` the gripper's distance to a target."""

    name: str
    value: Potential
    weight: float = 1.0
    per_decision = True

    def reset(self) -> None:
        pass

    def __call__(self) -> float:
        return self.weight * float(self.value())


@dataclass
class EventReward:
    """``weight`` once, on the first step at which ``happened()`` is true (success, button).

    ``per_decision`` events are checked only when a decision ends (a subgoal, or a joint-velocity
    step): a success event, because success is judged where a subgoal ends. Checked every 0.1 s
    while a base subgoal drove, it paid +10 for passing through the goal region without stopping
    there (PointNav runs learned to: 90% of episodes were paid, 63% succeeded); the original
    teleported the base to the subgoal's end, so only that pose counted. A latched state (a pressed
    button) is checked every 0.1 s."""

    name: str
    happened: Callable[[], bool]
    weight: float = 10.0
    per_decision: bool = False
    _given: bool = field(default=False, init=False, repr=False)

    def reset(self) -> None:
        self._given = bool(self.happened())

    def __call__(self) -> float:
        if self._given or not self.happened():
            return 0.0
        self._given = True
        return self.weight


RewardTerm = PotentialReward | StateReward | EventReward


def spl(success: bool, shortest_path_length: float, driven_path_length: float) -> float:
    """Success weighted by (normalised inverse) Path Length, Anderson et al. 2018."""
    if not success:
        return 0.0
    if shortest_path_length <= 0.0:
        return 1.0
    return float(shortest_path_length / max(driven_path_length, shortest_path_length))
