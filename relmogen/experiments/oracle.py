"""``relmogen oracle``: scripted (or random) subgoal policies over many episodes."""

from __future__ import annotations

from pathlib import Path

from relmogen.agents.oracles import make_policy
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.rollout import aggregate, run_episode, run_episodes
from relmogen.visualisation.views import write_animation


def run_oracle(task: str, episodes: int, policy: str = "oracle", control: str = "subgoal-r", seed: int = 0,
               scene: str | None = None, base_planner: str = "rrt_connect", arm_planner: str = "rrt_connect",
               arm_collision: bool = True, quiet: bool = False, gif: Path | None = None) -> dict:
    if control != "subgoal-r":
        raise ValueError(f"oracles act through control 'subgoal-r', got {control!r}")
    env = RelmogenEnv(task=task, control=control, scene=scene, base_planner=base_planner,
                      arm_planner=arm_planner, arm_collision=arm_collision)
    agent = make_policy(policy, env)
    records = run_episodes(env, agent.act, episodes, seed, quiet, on_reset=agent.reset,
                           description=f"{task} {policy}")
    result = {"task": task, "policy": policy, "scene": env.scene.name, "base_planner": base_planner,
              "arm_planner": arm_planner, "arm_collision": arm_collision, **aggregate(records)}
    if gif is not None:
        record = run_episode(env, agent.act, seed, record_frames=True, on_reset=agent.reset)
        result["gif"] = str(write_animation(record.frames, gif, fps=8))
    env.close()
    return result
