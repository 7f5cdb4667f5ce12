"""Skip no-ops (``relmogen eval --skip-no-ops``; ours, a test-time rule never used in training).

A deterministic subgoal policy whose subgoal changed nothing it sees gets the same observation
back and chooses the same subgoal until the episode ends.

* SGP-D: ``NoOpMemory`` excludes a subgoal after which the view was unchanged
  (``relmogen.envs.relmogen_env.view_unchanged``) until the view changes, so the policy falls
  back to its next best subgoal. ``relmogen.agents.dqn.env_policy`` applies it with
  ``skip_no_ops=True``. Measured in ``results/sgpd-nstep-long``.
* SGP-R: ``sample_after_no_ops`` takes the policy's mean subgoal, except right after a subgoal
  that left the view unchanged, when it samples one from the policy's own distribution (what the
  stochastic policy does at every step). Measured in ``results/pushdoornav-table1-second``.

Evaluations report either as its own policy (``deterministic-skip-no-ops``), never as the plain
deterministic figure.
"""

from __future__ import annotations

import numpy as np

from relmogen.envs.relmogen_env import VIEW_KEYS, view_unchanged


def view_of(obs: dict) -> dict:
    """A copy of what ``view_unchanged`` compares."""
    return {key: np.array(obs[key]) for key in VIEW_KEYS if key in obs}


class NoOpMemory:
    """The actions to exclude in each state of one episode; call ``clear`` at every episode start."""

    def __init__(self):
        self.clear()

    def clear(self) -> None:
        self.previous: tuple[dict, int] | None = None
        self.excluded: list[int] = []

    def excluded_now(self, obs: dict) -> list[int]:
        """The actions to exclude in ``obs``, given the previous observation and action."""
        if self.previous is not None and view_unchanged(self.previous[0], obs):
            self.excluded.append(self.previous[1])
        else:
            self.excluded = []
        return self.excluded

    def chose(self, obs: dict, action: int) -> None:
        self.previous = (view_of(obs), int(action))


def sample_after_no_ops(model):
    """``obs -> action`` of an SB3 actor-critic ``model`` (SGP-R): deterministic, except that after a
    step that left the view unchanged the action is sampled; ``reset`` starts an episode."""
    previous: list[dict] = []

    def act(obs):
        stuck = bool(previous) and view_unchanged(previous[0], obs)
        previous[:] = [view_of(obs)]
        return model.predict(obs, deterministic=not stuck)[0]

    act.reset = previous.clear
    return act
