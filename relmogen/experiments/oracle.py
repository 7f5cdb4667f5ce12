"""``relmogen oracle``: scripted (or random) subgoal policies over many episodes."""

from __future__ import annotations

from pathlib import Path

from relmogen.agents.oracles import make_policy
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.rollout import aggregate, run_episode, run_episodes
from relmogen.visualisation.views import write_animation

ORACLE_CONTROLS = ("subgoal-r", "subgoal-d")


def run_oracle(task: str, episodes: int, policy: str = "oracle", control: str = "subgoal-r", seed: int = 0,
               scene: str | None = None, base_planner: str = "rrt_connect", arm_planner: str = "rrt_connect",
               arm_collision: bool = True, quiet: bool = False, gif: Path | None = None, image_size: int = 128,
               push_frame: str = "base") -> dict:
    """Oracles decide in ``subgoal-r`` actions. Through ``control="subgoal-d"`` each one is
    executed as the nearest discrete action (``SubgoalDControl.nearest_index``): the ceiling of
    SGP-D's action space at that image size and push frame."""
    if control not in ORACLE_CONTROLS:
        raise ValueError(f"oracles act through {' or '.join(ORACLE_CONTROLS)}, got control {control!r}")
    if control == "subgoal-d" and policy != "oracle":
        raise ValueError("random subgoal-d actions are measured by scripts/measure_sgpd_exploration.py "
                         "(uniform over the allowed actions, as relmogen-d explores)")
    options = {"push_frame": push_frame} if control == "subgoal-d" else {}
    env = RelmogenEnv(task=task, control=control, scene=scene, base_planner=base_planner, arm_planner=arm_planner,
                      arm_collision=arm_collision, image_size=image_size, **options)
    agent = make_policy(policy, env)
    act = agent.act if control == "subgoal-r" else (lambda obs: env.control.nearest_index(agent.act(obs)))
    records = run_episodes(env, act, episodes, seed, quiet, on_reset=agent.reset,
                           description=f"{task} {policy}")
    result = {"task": task, "policy": policy, "control": control, "image_size": image_size, **options,
              "scene": env.scene.name, "base_planner": base_planner, "arm_planner": arm_planner,
              "arm_collision": arm_collision, **aggregate(records)}
    if gif is not None:
        record = run_episode(env, act, seed, record_frames=True, on_reset=agent.reset)
        result["gif"] = str(write_animation(record.frames, gif, fps=8))
    env.close()
    return result
