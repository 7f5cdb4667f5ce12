"""How often does SGP-D's random exploration reach the reward on a task?

Runs the epsilon = 1 policy of ``relmogen-d`` (random actions over the allowed ones) with two
samplers: ``uniform`` (every allowed action equally likely, what training does) and
``part-coin`` (base or arm with probability 1/2 each, then uniform within the part, as
SGP-R's a0 does). Prints one JSON object with the task metrics of each.

    python results/sgpd-first/measure_sgpd_exploration.py --task ButtonDoorNav --episodes 30 --sampler uniform
"""

from __future__ import annotations

import argparse
import json

import numpy as np
import torch as th

from relmogen.agents.dqn import (PUSH_BINS, YAW_BINS, allowed_actions, info_masks, map_side, sample_allowed,
                                 without_arm_mask)
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import PUSH_FRAMES
from relmogen.experiments.rollout import aggregate, run_episodes
from relmogen.tasks import task_class


def part_coin(allowed: np.ndarray, q: int) -> np.ndarray:
    """Per row: pick base or arm with probability 1/2 (the other if the pick has no allowed
    action), then an allowed action of that part uniformly."""
    base_end = YAW_BINS * q * q
    restricted = allowed.copy()
    for row in restricted:
        base, arm = slice(0, base_end), slice(base_end, None)
        chosen, other = (base, arm) if np.random.rand() < 0.5 else (arm, base)
        if row[chosen].any():
            row[other] = False
    return sample_allowed(restricted)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", required=True)
    parser.add_argument("--episodes", type=int, default=30)
    parser.add_argument("--sampler", choices=("uniform", "part-coin"), default="uniform")
    parser.add_argument("--image-size", type=int, default=64)
    parser.add_argument("--mask-arm", action=argparse.BooleanOptionalAction, default=True,
                        help="sample only arm pixels with depth within the arm's reach (relmogen-d's default)")
    parser.add_argument("--push-frame", choices=PUSH_FRAMES, default="base", help="env.push_frame of relmogen-d")
    args = parser.parse_args()
    np.random.seed(0)
    env = RelmogenEnv(task=args.task, control="subgoal-d", image_size=args.image_size, push_frame=args.push_frame)
    q, parts = map_side(env.action_space.n), task_class(args.task).subgoal_parts
    assert env.action_space.n == (YAW_BINS + PUSH_BINS) * q * q

    def act(_obs):
        masks = info_masks(env.unwrapped.control.extra_info(), q)
        masks = masks if args.mask_arm else without_arm_mask(masks)
        allowed = allowed_actions(th.as_tensor(masks[None]), parts).numpy()
        return int((sample_allowed(allowed) if args.sampler == "uniform" else part_coin(allowed, q))[0])

    try:
        records = run_episodes(env, act, args.episodes, seed=100_000, quiet=True)
    finally:
        env.close()
    print(json.dumps({"task": args.task, "sampler": args.sampler, "mask_arm": args.mask_arm,
                      "push_frame": args.push_frame, **aggregate(records)}))


if __name__ == "__main__":
    main()
