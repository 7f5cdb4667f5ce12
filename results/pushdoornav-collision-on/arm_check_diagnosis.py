"""How often a random arm subgoal in front of the PushDoorNav door gets a collision-checked plan,
for several allowances of the gripper inside the pushed body (COMMANDS.md, "Arm collision checks").

    python results/pushdoornav-collision-on/arm_check_diagnosis.py [--trials 80]

Each trial puts the base 0.4-1.0 m before the closed door (lateral offset up to 0.6 m, yaw within
0.5 rad of facing the push bar), picks a uniform random pixel of the 64 px depth image and, for a
point within the arm's reach, runs the arm's IK and joint-space plan (RRT-Connect) as a subgoal
would. Every setting replays the same trials. Prints one line per setting: trials, plans found and
the failure reasons.
"""

from __future__ import annotations

import argparse
import collections
from dataclasses import replace

import numpy as np

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import within_arm_reach

SETTINGS = {
    "no checking (training in the paper)": {"collision_checking": False},
    "pushed body 0.03 m (as any body; before)": {"target_penetration_allowance": 0.03},
    "pushed body 0.05 m": {"target_penetration_allowance": 0.05},
    "pushed body 0.08 m (now)": {"target_penetration_allowance": 0.08},
    "pushed body 0.10 m": {"target_penetration_allowance": 0.10},
}


def trials(env: RelmogenEnv, count: int, seed: int = 0):
    """(base pose, pixel) pairs whose pixel sees a point within reach."""
    rng, door = np.random.default_rng(seed), env.task.door
    normal = np.asarray(env.task.doorway.normal)
    found = []
    while len(found) < count:
        bar = door.face_point(0.45, door.bar_height)
        base = bar[:2] - rng.uniform(0.4, 1.0) * normal + rng.uniform(-0.6, 0.6) * door.closed_direction
        yaw = float(np.arctan2(*(bar[:2] - base)[::-1])) + rng.uniform(-0.5, 0.5)
        pixel = tuple(int(v) for v in rng.integers(0, env.camera.intrinsics.width, 2))
        env.robot.set_base_pose(base[0], base[1], yaw)
        frame = capture(env)
        if frame.has_point(pixel[1], pixel[0]):
            point = env.camera.pixel_to_world(frame, *pixel)
            if within_arm_reach(env, point[None])[0]:
                found.append((base, yaw, point))
    return found


def capture(env: RelmogenEnv):
    env.robot.set_joint_positions(env.robot.arm_joint_indices, env.control.mg.arm.default_config)
    env._observe()
    return env.last_frame


def plan_rate(env: RelmogenEnv, cases, overrides: dict) -> tuple[int, collections.Counter]:
    arm = env.control.mg.arm
    arm.config = replace(env.control.mg._arm_config(), **overrides)
    arm.checker._target_threshold = -arm.config.target_penetration_allowance
    rng, planned, reasons = np.random.default_rng(1), 0, collections.Counter()
    for base, yaw, point in cases:
        env.robot.set_base_pose(base[0], base[1], yaw)
        capture(env)
        arm.checker.target_body = arm.body_at(point)
        ik = arm.solve_ik(point, rng)
        plan = arm.plan(ik.config, rng) if ik.config is not None else None
        arm.checker.target_body = None
        if plan is not None and plan.success:
            planned += 1
        else:
            reasons[ik.reason if plan is None else f"plan: {plan.reason}"] += 1
    return planned, reasons


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=80)
    args = parser.parse_args()
    env = RelmogenEnv(task="PushDoorNav", control="subgoal-r", image_size=64)
    env.reset(seed=3)
    cases = trials(env, args.trials)
    for name, overrides in SETTINGS.items():
        planned, reasons = plan_rate(env, cases, overrides)
        print(f"{name}: {planned}/{len(cases)} planned ({planned / len(cases):.2f}); failures {dict(reasons)}")


if __name__ == "__main__":
    main()
