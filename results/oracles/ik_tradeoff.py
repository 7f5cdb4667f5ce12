"""What ArmConfig's IK restarts, plan attempts and push waypoints cost and buy (ik_tradeoff.md).

    python results/oracles/ik_tradeoff.py random [--tasks T ...] [--episodes N] SETTING ...
    python results/oracles/ik_tradeoff.py oracle --task T [--episodes N] SETTING

SETTING is ``name`` or ``name=key:value,key:value`` with ArmConfig fields (``ik_restarts``,
``plan_attempts``, ``push_points``, ``push_steps_per_point``, ...) applied over the current
defaults; ``reach_check:0`` skips the arm-reach check before IK (the code before it).

``random``: mean wall time of a full ``env.step`` of uniform random subgoal-r actions at image
size 64 with arm collision checking off (the training setting). Episodes (seeds 0, 1, ...) are
interleaved over the settings, each setting replaying the same seed and action stream, so
machine load hits them alike. Prints one markdown row per task and setting.

``oracle``: ``relmogen oracle --task T --policy oracle --episodes N --json`` (rrt_connect, arm
collision on, image size 128) with the setting applied; prints the same JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from contextlib import contextmanager
from dataclasses import replace

import numpy as np

from relmogen.envs import subgoal_controls
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import within_arm_reach
from relmogen.motion_generation.generator import MotionGenerator

RANDOM_TASKS = ("PushDoorNav", "ButtonDoorNav")


def parse_setting(text: str) -> tuple[str, dict]:
    name, _, body = text.partition("=")
    overrides = {}
    for item in filter(None, body.split(",")):
        key, _, value = item.partition(":")
        overrides[key] = int(value) if value.lstrip("-").isdigit() else float(value)
    return name, overrides


@contextmanager
def applied(overrides: dict, env: RelmogenEnv | None = None):
    """ArmConfig overrides (for every MotionGenerator made inside, and ``env``'s), reach check on/off."""
    overrides = dict(overrides)
    reach_check = bool(overrides.pop("reach_check", 1))
    arm_config, within = MotionGenerator._arm_config, subgoal_controls.within_arm_reach
    MotionGenerator._arm_config = lambda self: replace(arm_config(self), **overrides)
    if not reach_check:
        subgoal_controls.within_arm_reach = lambda env_, points: np.ones(np.shape(points)[:-1], dtype=bool)
    if env is not None:
        env.control.mg.arm.config = env.control.mg._arm_config()
    try:
        yield
    finally:
        MotionGenerator._arm_config, subgoal_controls.within_arm_reach = arm_config, within


def random_steps(task: str, settings: list[tuple[str, dict]], episodes: int) -> dict[str, list[dict]]:
    env = RelmogenEnv(task=task, control="subgoal-r", image_size=64, arm_collision=False)
    steps: dict[str, list[dict]] = {name: [] for name, _ in settings}
    for episode in range(episodes):
        for name, overrides in settings:
            with applied(overrides, env):
                env.reset(seed=episode)
                env.action_space.seed(episode)
                done = False
                while not done:
                    action = env.action_space.sample()
                    beyond = beyond_reach(env, action)
                    start = time.perf_counter()
                    _, _, terminated, truncated, info = env.step(action)
                    wall = time.perf_counter() - start
                    done = terminated or truncated
                    steps[name].append({"ms": 1000 * wall, "kind": info["subgoal_type"], "ok": info["plan_found"],
                                        "plan_ms": 1000 * float(info["planning_time_s"]),
                                        "beyond_reach": beyond, "planned_beyond": beyond and info["plan_found"]})
    env.close()
    return steps


def beyond_reach(env: RelmogenEnv, action: np.ndarray) -> bool:
    """Whether a subgoal-r action is an arm subgoal at a point beyond the arm's reach (whether
    or not the reach check is on)."""
    part, target = env.control.decode_continuous(action)
    if part != "arm" or env.last_frame.depth[target[0], target[1]] <= 0:
        return False
    return not bool(within_arm_reach(env, env.camera.pixel_to_world(env.last_frame, target[1], target[0])))


def summarise(task: str, name: str, overrides: dict, steps: list[dict]) -> str:
    arm = [s for s in steps if s["kind"] == "arm"]
    mean = lambda rows, key: float(np.mean([r[key] for r in rows])) if rows else float("nan")  # noqa: E731
    setting = ", ".join(f"{k}={v}" for k, v in overrides.items()) or "defaults"
    return (f"| {task} | {name} | {setting} | {len(steps)} | {mean(steps, 'ms'):.1f} | {mean(arm, 'ms'):.1f} | "
            f"{mean(arm, 'plan_ms'):.1f} | {mean(arm, 'ok'):.3f} | {mean(arm, 'beyond_reach'):.3f} | "
            f"{sum(s['planned_beyond'] for s in arm)} |")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("mode", choices=("random", "oracle"))
    parser.add_argument("settings", nargs="+")
    parser.add_argument("--tasks", nargs="+", default=list(RANDOM_TASKS))
    parser.add_argument("--task")
    parser.add_argument("--episodes", type=int, default=None)
    args = parser.parse_args(argv)
    settings = [parse_setting(text) for text in args.settings]
    if args.mode == "random":
        print("| task | setting | overrides | steps | step ms | arm step ms | arm IK+plan ms | arm plan rate | "
              "arm beyond reach | planned beyond reach |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for task in args.tasks:
            steps = random_steps(task, settings, args.episodes or 20)
            for name, overrides in settings:
                print(summarise(task, name, overrides, steps[name]), flush=True)
        return 0
    from relmogen.experiments.oracle import run_oracle

    if len(settings) != 1 or not args.task:
        parser.error("oracle mode takes --task and one SETTING")
    start = time.perf_counter()
    with applied(settings[0][1]):
        result = run_oracle(args.task, args.episodes or 50, "oracle", quiet=True)
    print(f"{args.task} {settings[0][0]}: {time.perf_counter() - start:.0f} s", file=sys.stderr)
    print(json.dumps(result, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
