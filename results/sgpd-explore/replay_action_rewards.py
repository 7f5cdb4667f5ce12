"""Mean reward per step in a relmogen-d replay, overall and for given actions: REPLAY_PKL [BIN,I,J ...].

Compares the Q values a checkpoint gives (``oracle_action_values.py``) with what the replay's
transitions earned: at gamma 0.95 a value is about 20 x the mean reward per step of the policy.
Also lists the most frequent actions with their mean reward and share of rewards above 0.5.

    python results/sgpd-explore/replay_action_rewards.py RUN/checkpoints/replay_0001500/replay_buffer.pkl 5,8,15 5,12,15 9,16,14
"""

from __future__ import annotations

import pickle
import sys

import numpy as np

from relmogen.envs.subgoal_controls import PUSH_BINS, YAW_BINS


def describe(index: int, q: int) -> tuple:
    part, offset = ("base", index) if index < YAW_BINS * q * q else ("arm", index - YAW_BINS * q * q)
    bin_, cell = divmod(offset, q * q)
    return (part, bin_, *divmod(cell, q))


def main() -> None:
    with open(sys.argv[1], "rb") as handle:
        buffer = pickle.load(handle)
    rows = buffer.buffer_size if buffer.full else buffer.pos
    actions = buffer.actions[:rows].reshape(-1).astype(int)
    rewards = buffer.rewards[:rows].reshape(-1)
    q = int(round(np.sqrt(buffer.action_space.n / (YAW_BINS + PUSH_BINS))))
    arm = actions >= YAW_BINS * q * q
    print(f"{actions.size} transitions; mean reward per step {rewards.mean():.3f} (arm {rewards[arm].mean():.3f}, "
          f"base {rewards[~arm].mean():.3f}); arm share {arm.mean():.3f}; rewards > 0.5: {(rewards > 0.5).sum()}")
    for spec in sys.argv[2:]:
        bin_, i, j = (int(v) for v in spec.split(","))
        chosen = actions == YAW_BINS * q * q + bin_ * q * q + i * q + j
        mean = f"{rewards[chosen].mean():.3f}" if chosen.any() else "-"
        print(f"arm bin {bin_} cell ({i}, {j}): {chosen.sum()} times, mean reward {mean}")
    values, counts = np.unique(actions, return_counts=True)
    for value, count in zip(values[np.argsort(-counts)[:8]], np.sort(counts)[::-1][:8]):
        chosen = actions == value
        print(f"{describe(int(value), q)}: {count} times, mean reward {rewards[chosen].mean():.3f}, "
              f"rewards > 0.5 in {(rewards[chosen] > 0.5).mean():.3f}")


if __name__ == "__main__":
    main()
