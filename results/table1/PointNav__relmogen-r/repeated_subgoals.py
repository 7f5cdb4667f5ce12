"""Why a greedy SGP-R policy repeats subgoals: run N deterministic episodes (seeds 100000+, arm
collision on) and count each subgoal by (same action as the previous step, the motion generator's
reason, distance driven under 0.1 m). Usage: python repeated_subgoals.py RUN_DIR EPISODES"""

import collections
import sys

import numpy as np

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.evaluate import load_policy
from relmogen.experiments.train import env_kwargs


def count_subgoals(run_dir: str, episodes: int) -> tuple[float, collections.Counter]:
    model, config, _ = load_policy(run_dir)
    env = RelmogenEnv(**env_kwargs(config, True))
    reasons, successes = collections.Counter(), 0
    for episode in range(episodes):
        obs, info = env.reset(seed=100000 + episode)
        previous, done = None, False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
            repeated = previous is not None and np.allclose(action, previous)
            moved = ">0.1 m" if info["path_length_m"] >= 0.1 else "<0.1 m"
            reasons[(repeated, info["reason"][:40], moved)] += 1
            previous = action
        successes += info["is_success"]
    env.close()
    return successes / episodes, reasons


if __name__ == "__main__":
    rate, reasons = count_subgoals(sys.argv[1], int(sys.argv[2]))
    print("SR", rate)
    for (repeated, reason, moved), count in reasons.most_common(15):
        print(count, "repeated" if repeated else "new", reason, moved)
