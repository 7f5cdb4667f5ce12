"""The main job of the README: a trained ReLMoGen-R policy solving PushDoorNav, no training first.

The policy ships with the package (``relmogen/policies/PushDoorNav-relmogen-r``: the actor
of seed 2 of ``results/table1/PushDoorNav__relmogen-r``, see its ``provenance.json``). It is run
deterministically with arm collision checking on, as at evaluation; the metrics are the ones
``relmogen eval`` prints and the first episode is written as a GIF of a third-person view, or,
with ``video``, as the annotated recording of ``relmogen eval --video``.
"""

from __future__ import annotations

from pathlib import Path

from relmogen.experiments.shipped import open_shipped, shipped_policy_dir
from relmogen.experiments.rollout import aggregate, run_episodes
from relmogen.experiments.video import VIDEO_FPS, AnnotatedRecorder
from relmogen.simulation.views import check_animation_path, write_animation

DEMO_POLICY = "PushDoorNav-relmogen-r"
GIF_FPS = 8


def run_demo(episodes: int = 1, seed: int = 0, out_dir: Path = Path("out/demo"), quiet: bool = False,
             policy_name: str = DEMO_POLICY, video: Path | None = None) -> dict:
    """Metrics of ``episodes`` episodes of the shipped policy; the first one goes to a GIF in
    ``out_dir`` (``gif``), or annotated to ``video`` (a .gif or .mp4 path; ``video``)."""
    if video is not None:
        check_animation_path(video)
    env, policy = open_shipped(shipped_policy_dir(policy_name))
    recorder = AnnotatedRecorder() if video is not None else None
    try:
        records = run_episodes(env, policy.act, episodes, seed, quiet, record_first=True, first_recorder=recorder,
                               description=f"{policy.config.task} {policy.config.algo}")
    finally:
        env.close()
    if video is None:
        recording = {"gif": str(write_animation(records[0].frames, Path(out_dir) /
                                                f"{policy.config.task.lower()}_episode0.gif", fps=GIF_FPS))}
    else:
        recording = {"video": str(write_animation(records[0].frames, video, fps=VIDEO_FPS))}
    return {"task": policy.config.task, "policy": policy_name, "seed": seed, **aggregate(records),
            **recording, "trained_episodes": policy.provenance.get("episodes")}
