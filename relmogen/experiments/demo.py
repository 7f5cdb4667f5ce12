"""The main job of the README: a trained ReLMoGen-R policy solving PushDoorNav, no training first.

The policy ships with the package (``relmogen/policies/PushDoorNav-relmogen-r``: the actor
of one of the runs in ``results/pushdoornav-first``, see its ``provenance.json``). It is run
deterministically with arm collision checking on, as at evaluation; the metrics are the ones
``relmogen eval`` prints and the first episode is written as a GIF of a third-person view.
"""

from __future__ import annotations

from pathlib import Path

from relmogen.agents.shipped import open_shipped, shipped_policy_dir
from relmogen.experiments.rollout import aggregate, run_episodes
from relmogen.visualisation.views import write_animation

DEMO_POLICY = "PushDoorNav-relmogen-r"


def run_demo(episodes: int = 1, seed: int = 0, out_dir: Path = Path("out/demo"), quiet: bool = False,
             policy_name: str = DEMO_POLICY) -> dict:
    env, policy = open_shipped(shipped_policy_dir(policy_name))
    try:
        records = run_episodes(env, policy.act, episodes, seed, quiet, record_first=True,
                               description=f"{policy.config.task} {policy.config.algo}")
    finally:
        env.close()
    gif = write_animation(records[0].frames, Path(out_dir) / f"{policy.config.task.lower()}_episode0.gif", fps=8)
    return {"task": policy.config.task, "policy": policy_name, "seed": seed, **aggregate(records),
            "gif": str(gif), "trained_episodes": policy.provenance.get("episodes")}
