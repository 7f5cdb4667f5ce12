"""The main job of the README: a short PointNav run with a GIF of a third-person view.

The policy is the scripted waypoint follower on joint velocities (until a trained subgoal
policy ships with the package).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rich.progress import Progress

from relmogen.agents.scripted import WaypointFollower
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.visualisation.views import write_animation

FRAME_EVERY = 3  # control steps between GIF frames (0.3 s)


def run_demo(episodes: int = 1, seed: int = 0, out_dir: Path = Path("out/demo"), quiet: bool = False) -> dict:
    env = RelmogenEnv(task="PointNav", control="joint", render_mode="rgb_array")
    policy = WaypointFollower(env.robot.spec)
    results = []
    with Progress(disable=quiet, transient=True) as progress:
        for episode in range(episodes):
            bar = progress.add_task(f"episode {episode + 1}/{episodes}", total=env.control.episode_steps)
            obs, _ = env.reset(seed=seed + episode)
            frames, done, info = [env.render()], False, {}
            while not done:
                obs, _, terminated, truncated, info = env.step(policy(obs))
                done = terminated or truncated
                if env.elapsed_steps % FRAME_EVERY == 0 or done:
                    frames.append(env.render())
                progress.advance(bar)
            gif = write_animation(frames, Path(out_dir) / f"pointnav_episode{episode}.gif")
            results.append(dict(info["metrics"], steps=env.elapsed_steps, termination=info["termination"]))
    env.close()
    summary = {key: float(np.mean([r[key] for r in results])) for key in ("success", "spl", "path_length")}
    return {
        "task": "PointNav",
        "episodes": episodes,
        "success_rate": summary["success"],
        "spl": summary["spl"],
        "mean_path_length": summary["path_length"],
        "mean_steps": float(np.mean([r["steps"] for r in results])),
        "gif": str(gif),
    }
