"""Run policies for whole episodes and aggregate the task metrics with the project's keys.

Every command that prints metrics uses the same keys: ``success_rate``, ``spl``,
``closed_5``, ``closed_10`` (items closed / chairs tucked at the tight and loose tolerance,
mean per episode), ``episodes``, plus MG statistics when subgoal controls are used
(``repeated_subgoal_rate``: the share of subgoals equal to the previous one of their episode;
``unchanged_view_rate``: the share after which the camera image and local map were exactly as
before, ``relmogen.envs.relmogen_env.view_unchanged``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from rich.console import Console
from rich.progress import Progress

from relmogen.envs.relmogen_env import RelmogenEnv, view_unchanged

Policy = Callable[[dict], np.ndarray]


@dataclass
class EpisodeRecord:
    metrics: dict[str, float]
    episode_return: float
    steps: int
    termination: str | None
    subgoals: list[dict] = field(default_factory=list)  # per-step MG info (subgoal controls)
    frames: list[np.ndarray] = field(default_factory=list)


FRAME_PERIOD_S = 0.4  # simulated seconds between video frames while a subgoal executes


class FrameRecorder:
    """Third-person frames of one episode: after the reset, every ``FRAME_PERIOD_S`` of simulated
    time while a subgoal executes (the environment's ``frame_hook``) and after each step.
    ``relmogen.experiments.video.AnnotatedRecorder`` draws what the policy chose on them."""

    def __init__(self) -> None:
        self.frames: list[np.ndarray] = []
        self.env: RelmogenEnv | None = None
        self.last_frame_time = 0.0

    def start(self, env: RelmogenEnv, obs: dict) -> None:
        """After the reset: the first frame, and the hook for frames while subgoals execute."""
        self.env, self.last_frame_time = env, env.sim_time
        env.frame_hook = self.during_step
        self.frames.append(self.frame())

    def before_step(self, obs: dict, action) -> None:
        """The action the policy chose on ``obs``, before the environment executes it."""

    def during_step(self) -> None:
        if self.env.sim_time - self.last_frame_time >= FRAME_PERIOD_S:
            self.frames.append(self.frame())
            self.last_frame_time = self.env.sim_time

    def after_step(self, obs: dict, reward: float, info: dict) -> None:
        self.frames.append(self.frame())

    def frame(self) -> np.ndarray:
        return self.env.third_person_image()


def run_episode(env: RelmogenEnv, act: Policy, seed: int, record_frames: bool = False,
                on_reset: Callable[[], None] | None = None, recorder: FrameRecorder | None = None) -> EpisodeRecord:
    """One episode; ``recorder`` (with ``record_frames``, a plain ``FrameRecorder``) keeps its frames."""
    recorder = recorder or (FrameRecorder() if record_frames else None)
    obs, _ = env.reset(seed=seed)
    if on_reset is not None:
        on_reset()
    if recorder is not None:
        recorder.start(env, obs)
    subgoals, done, info, previous = [], False, {}, None
    while not done:
        action = act(obs)
        if recorder is not None:
            recorder.before_step(obs, action)
        before = obs
        obs, reward, terminated, truncated, info = env.step(action)
        done = terminated or truncated
        if "subgoal_type" in info:
            subgoals.append({k: info[k] for k in ("subgoal_type", "plan_found", "reason", "planner")})
            subgoals[-1]["repeat"] = previous is not None and np.array_equal(action, previous)
            subgoals[-1]["unchanged_view"] = view_unchanged(before, obs)
        previous = action
        if recorder is not None:
            recorder.after_step(obs, reward, info)
    env.frame_hook = None
    frames = recorder.frames if recorder is not None else []
    return EpisodeRecord(info["metrics"], env.episode_return, env.elapsed_steps, info["termination"], subgoals, frames)


def run_episodes(env: RelmogenEnv, act: Policy, episodes: int, seed: int = 0, quiet: bool = False,
                 on_reset: Callable[[], None] | None = None, description: str = "episodes",
                 record_first: bool = False, first_recorder: FrameRecorder | None = None) -> list[EpisodeRecord]:
    """``episodes`` episodes with seeds ``seed, seed + 1, ...``; ``record_first`` keeps the
    video frames of the first one, ``first_recorder`` records it with that recorder instead."""
    records = []
    # on stderr, so that a JSON result on stdout stays parseable while the bar runs
    with Progress(disable=quiet, transient=True, console=Console(stderr=True)) as progress:
        bar = progress.add_task(description, total=episodes)
        for episode in range(episodes):
            first = episode == 0
            records.append(run_episode(env, act, seed + episode, record_frames=record_first and first,
                                       on_reset=on_reset, recorder=first_recorder if first else None))
            progress.advance(bar)
    return records


def aggregate(records: list[EpisodeRecord]) -> dict[str, float]:
    """Means over episodes with the project-wide keys."""
    if not records:
        raise ValueError("no episodes to aggregate")
    keys = sorted({k for r in records for k in r.metrics})
    mean = {k: float(np.mean([r.metrics.get(k, 0.0) for r in records])) for k in keys}
    result = {
        "episodes": len(records),
        "success_rate": mean.pop("success", 0.0),
        "spl": mean.pop("spl", 0.0),
        "closed_5": mean.pop("closed_5", 0.0),
        "closed_10": mean.pop("closed_10", 0.0),
        "mean_return": float(np.mean([r.episode_return for r in records])),
        "mean_steps": float(np.mean([r.steps for r in records])),
    }
    result.update(mean)
    result.update(_subgoal_statistics(records))
    return result


def _subgoal_statistics(records: list[EpisodeRecord]) -> dict[str, float]:
    subgoals = [s for r in records for s in r.subgoals]
    if not subgoals:
        return {}
    base = [s for s in subgoals if s["subgoal_type"] == "base"]
    return {
        "subgoal_success_rate": float(np.mean([s["plan_found"] for s in subgoals])),
        "base_fraction": len(base) / len(subgoals),
        "base_plan_rate": float(np.mean([s["plan_found"] for s in base])) if base else 0.0,
        "arm_plan_rate": float(np.mean([s["plan_found"] for s in subgoals if s["subgoal_type"] == "arm"]))
        if len(base) < len(subgoals) else 0.0,
        # A deterministic policy whose subgoal changed nothing sees the same observation and repeats it.
        "repeated_subgoal_rate": float(np.mean([s.get("repeat", False) for s in subgoals])),
        "unchanged_view_rate": float(np.mean([s.get("unchanged_view", False) for s in subgoals])),
    }
