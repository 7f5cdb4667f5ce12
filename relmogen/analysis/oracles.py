"""The floors and ceilings learning figures are read against.

``oracle_rows``: the ``relmogen oracle --json`` results in a folder (scripts/measure_oracles.sh
writes them) as rows of one table. ``random_sgpd``: SGP-D's exploration at epsilon = 1, random
actions over the allowed ones (``uniform``, what relmogen-d training does, or ``part-coin``: base
or arm with probability 1/2 each, then uniform within the part, as SGP-R's a0 does), through the
``relmogen oracle`` metrics.

    relmogen analyse oracle-table DIR [--json]
    relmogen analyse random-sgpd --task T [--episodes 30] [--sampler uniform|part-coin] [--push-frame base|surface]
                                 [--no-mask-arm] [--image-size 64] [--seed 100000] [--json]
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

ORACLE_KEYS = ("success_rate", "spl", "closed_5", "closed_10", "closed_10_fraction", "subgoal_success_rate",
               "mean_steps")
SAMPLERS = ("uniform", "part-coin")


def oracle_rows(folder: Path) -> list[dict]:
    """The ``relmogen oracle`` JSONs in ``folder`` (those with ``task`` and ``policy``), by file name."""
    rows = []
    for path in sorted(Path(folder).glob("*.json")):
        result = json.loads(path.read_text())
        if isinstance(result, dict) and "task" in result and "policy" in result:
            rows.append({"task": result["task"], "policy": result["policy"], "planners": result.get("base_planner"),
                         "episodes": result.get("episodes"), **{key: result.get(key) for key in ORACLE_KEYS}})
    return rows


def part_coin(allowed: np.ndarray, q: int) -> np.ndarray:
    """Per row: base or arm with probability 1/2 (the other if the pick has no allowed action),
    then an allowed action of that part uniformly."""
    from relmogen.agents.dqn import YAW_BINS, sample_allowed

    restricted = allowed.copy()
    base, arm = slice(0, YAW_BINS * q * q), slice(YAW_BINS * q * q, None)
    for row in restricted:
        chosen, other = (base, arm) if np.random.rand() < 0.5 else (arm, base)
        if row[chosen].any():
            row[other] = False
    return sample_allowed(restricted)


def random_sgpd(task: str, episodes: int = 30, sampler: str = "uniform", push_frame: str = "base",
                mask_arm: bool = True, image_size: int = 64, qmap_size: int | None = None, seed: int = 100_000,
                episode_steps: int | None = None, quiet: bool = True) -> dict:
    """The task metrics of SGP-D's random policy (arm collision checking on), episodes from
    ``seed``; numpy's global generator (which relmogen-d samples with) is seeded with 0."""
    import torch as th

    from relmogen.agents.dqn import allowed_actions, info_masks, map_side, sample_allowed, without_arm_mask
    from relmogen.envs.relmogen_env import RelmogenEnv
    from relmogen.experiments.rollout import aggregate, run_episodes
    from relmogen.tasks import task_class

    if sampler not in SAMPLERS:
        raise ValueError(f"unknown sampler {sampler!r}; valid: {', '.join(SAMPLERS)}")
    np.random.seed(0)
    env = RelmogenEnv(task=task, control="subgoal-d", image_size=image_size, push_frame=push_frame,
                      qmap_size=qmap_size, episode_steps=episode_steps)
    q, parts = map_side(env.action_space.n), task_class(task).subgoal_parts

    def act(_obs):
        masks = info_masks(env.control.extra_info(), q)
        masks = masks if mask_arm else without_arm_mask(masks)
        allowed = allowed_actions(th.as_tensor(masks[None]), parts).numpy()
        return int((sample_allowed(allowed) if sampler == "uniform" else part_coin(allowed, q))[0])

    try:
        records = run_episodes(env, act, episodes, seed=seed, quiet=quiet)
    finally:
        env.close()
    return {"task": task, "sampler": sampler, "mask_arm": mask_arm, "push_frame": push_frame,
            "image_size": image_size, "qmap_size": q, **aggregate(records)}
