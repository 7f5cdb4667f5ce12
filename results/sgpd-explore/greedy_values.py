"""What does a relmogen-d greedy policy value? Drives a checkpoint's greedy policy (arm collision
checking on) and records, per step: the chosen part, the best allowed base and arm Q values, the
reward, and whether the action repeated the previous one. Prints per-episode lines and a summary
JSON: is the greedy arm choice a zero-reward loop whose Q beats every base action?

    python results/sgpd-explore/greedy_values.py RUN --checkpoint latest --episodes 10 --seed 100000
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import YAW_BINS
from relmogen.experiments.evaluate import load_policy
from relmogen.experiments.train import env_kwargs
from relmogen.visualisation.qmap import q_map_state


def best_allowed(q_maps: np.ndarray, mask: np.ndarray) -> float:
    values = q_maps.max(axis=0)
    return float(values[mask].max()) if mask.any() else float("nan")


def greedy_episode(model, env: RelmogenEnv, seed: int) -> list[dict]:
    obs, _ = env.reset(seed=seed)
    steps, previous, done = [], None, False
    while not done:
        state = q_map_state(model, env, obs, len(steps))
        part, bin_, i, j = state.choice
        obs, reward, terminated, truncated, _ = env.step(env.unwrapped.control.encode(part, bin_, i, j))
        steps.append({"part": part, "base_q": best_allowed(state.q_maps[:YAW_BINS], state.masks[0]),
                      "arm_q": best_allowed(state.q_maps[YAW_BINS:], state.masks[1]), "reward": float(reward),
                      "repeat": state.choice == previous})
        previous, done = state.choice, terminated or truncated
    return steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--checkpoint", default="latest")
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--seed", type=int, default=100000)
    args = parser.parse_args()
    model, config, _ = load_policy(args.run, checkpoint=args.checkpoint)
    env = RelmogenEnv(**env_kwargs(config, arm_collision=True))
    all_steps = []
    try:
        for episode in range(args.episodes):
            steps = greedy_episode(model, env, args.seed + episode)
            all_steps += steps
            arm = [s for s in steps if s["part"] == "arm"]
            print(json.dumps({"seed": args.seed + episode, "steps": len(steps), "arm": len(arm),
                              "return": round(sum(s["reward"] for s in steps), 3),
                              "mean_base_q": round(float(np.nanmean([s["base_q"] for s in steps])), 3),
                              "mean_arm_q": round(float(np.nanmean([s["arm_q"] for s in steps])), 3),
                              "arm_reward": round(sum(s["reward"] for s in arm), 3),
                              "repeats": sum(s["repeat"] for s in steps)}))
    finally:
        env.close()
    arm = [s for s in all_steps if s["part"] == "arm"]
    print(json.dumps({"summary": True, "steps": len(all_steps), "arm_share": len(arm) / len(all_steps),
                      "arm_steps_reward_mean": float(np.mean([s["reward"] for s in arm])) if arm else None,
                      "base_q_mean": float(np.nanmean([s["base_q"] for s in all_steps])),
                      "arm_q_mean": float(np.nanmean([s["arm_q"] for s in all_steps])),
                      "base_q_below_zero": float(np.mean([s["base_q"] < 0 for s in all_steps])),
                      "repeat_share": float(np.mean([s["repeat"] for s in all_steps]))}))


if __name__ == "__main__":
    main()
