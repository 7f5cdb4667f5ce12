"""The arm's motion generator under other settings: what a subgoal costs, what it plans, what an
IK solution collides with.

A *setting* is a set of ``ArmConfig`` fields (``ik_restarts``, ``plan_attempts``, ``push_points``,
``push_steps_per_point``, ``push_sub_steps``, ``rrt_iterations``, ``target_penetration_allowance``,
...), plus ``collision_checking`` (the motion generator's arm collision checking) and
``arm_reach`` (the robot's mask radius, metres; a large value turns the reach check before IK
off). ``set_arm_settings`` gives an environment a motion generator built with them.

    relmogen analyse arm-settings random [--tasks T ...] [--episodes 20] [--image-size 64] [--set KEY=VALUE]
                                         NAME[=key:value,key:value] ...
    relmogen analyse arm-settings oracle --tasks T ... [--episodes 50] NAME[=key:value,...] ...
    relmogen analyse door-front [--trials 80] NAME[=key:value,...] ...
    relmogen analyse ik-contacts POLICY [--checkpoint best] --seeds S ... [--json]
"""

from __future__ import annotations

import collections
import dataclasses
import time
from pathlib import Path

import numpy as np
import pybullet as p

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import arm_base_distance, within_arm_reach
from relmogen.experiments.rollout import FrameRecorder, aggregate, run_episode, run_episodes
from relmogen.motion_generation.arm import ArmConfig
from relmogen.motion_generation.generator import MotionGenerator

DEFAULTS = "defaults"
EXTRA_KEYS = ("collision_checking", "arm_reach")


def parse_value(text: str):
    """``"3"`` -> 3, ``"0.05"`` -> 0.05, ``"none"`` -> None, ``"false"`` -> False, else the text."""
    lowered = text.strip().lower()
    if lowered in ("none", "null"):
        return None
    if lowered in ("true", "false", "on", "off"):
        return lowered in ("true", "on")
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def parse_setting(text: str) -> tuple[str, dict]:
    """``NAME`` or ``NAME=key:value,key:value`` -> (name, overrides), checked against ``ArmConfig``."""
    name, _, body = text.partition("=")
    overrides = {}
    for item in filter(None, body.split(",")):
        key, sep, value = item.partition(":")
        if not sep:
            raise ValueError(f"setting {text!r}: write key:value, got {item!r}")
        overrides[key.strip()] = parse_value(value)
    check_settings(overrides)
    return name or DEFAULTS, overrides


def check_settings(overrides: dict) -> None:
    valid = {f.name for f in dataclasses.fields(ArmConfig)} | set(EXTRA_KEYS)
    unknown = sorted(set(overrides) - valid)
    if unknown:
        raise ValueError(f"unknown arm setting {', '.join(unknown)}; valid: {', '.join(sorted(valid))}")


class ArmSettings:
    """Gives an environment's control a motion generator built with a setting, always from the
    configuration and robot spec the environment started with."""

    def __init__(self, env: RelmogenEnv):
        self.env = env
        self.config, self.spec = env.control.mg.config, env.robot.spec

    def apply(self, overrides: dict) -> None:
        check_settings(overrides)
        overrides = dict(overrides)
        reach = overrides.pop("arm_reach", None)
        self.env.robot.spec = self.spec if reach is None else dataclasses.replace(self.spec, arm_reach=float(reach))
        config = dataclasses.replace(self.config, arm=dataclasses.replace(self.config.arm))
        if "collision_checking" in overrides:
            config.arm_collision_checking = bool(overrides.pop("collision_checking"))
        config.arm = dataclasses.replace(config.arm, **overrides)
        self.env.control.mg = MotionGenerator(self.env, config)


def set_arm_settings(env: RelmogenEnv, overrides: dict) -> ArmSettings:
    """``env``'s control with a motion generator built with ``overrides``; returns the
    ``ArmSettings`` that can apply others (each from the original configuration)."""
    settings = ArmSettings(env)
    settings.apply(overrides)
    return settings


# ------------------------------------------------------------------------------ random steps
def beyond_reach(env: RelmogenEnv, action: np.ndarray, reach: float) -> bool:
    """Whether a ``subgoal-r`` action is an arm subgoal at a point farther than ``reach`` from the
    arm's base (whatever the robot's current mask)."""
    part, target = env.control.decode_continuous(action)
    if part != "arm" or not env.last_frame.has_point(target[0], target[1]):
        return False
    point = env.camera.pixel_to_world(env.last_frame, target[1], target[0])
    return bool(arm_base_distance(env, point) > reach)


def random_step_costs(task: str, settings: dict[str, dict], episodes: int = 20, image_size: int = 64,
                      arm_collision: bool = False, env_options: dict | None = None, seed: int = 0,
                      episode_steps: int | None = None) -> list[dict]:
    """Uniform random ``subgoal-r`` steps under each setting: one row per setting with the mean
    wall and CPU milliseconds per step and per arm step, the arm's IK + plan time, plan rate,
    share of arm subgoals beyond the reach and how many of those planned. Episodes (seeds
    ``seed``, ``seed`` + 1, ...) are interleaved over the settings, each replaying the same seed
    and action stream, so machine load hits them alike."""
    env = RelmogenEnv(task=task, control="subgoal-r", image_size=image_size, arm_collision=arm_collision,
                      episode_steps=episode_steps, **(env_options or {}))
    original_reach = env.robot.spec.arm_reach
    arm = ArmSettings(env)
    steps: dict[str, list[dict]] = {name: [] for name in settings}
    try:
        for episode in range(episodes):
            for name, overrides in settings.items():
                arm.apply(overrides)
                env.reset(seed=seed + episode)
                env.action_space.seed(seed + episode)
                done = False
                while not done:
                    action = env.action_space.sample()
                    beyond = beyond_reach(env, action, original_reach)
                    wall, cpu = time.perf_counter(), time.process_time()
                    _, _, terminated, truncated, info = env.step(action)
                    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
                    done = terminated or truncated
                    steps[name].append({"ms": 1000 * wall, "cpu_ms": 1000 * cpu, "kind": info["subgoal_type"],
                                        "ok": bool(info["plan_found"]), "plan_ms": 1000 * float(info["planning_time_s"]),
                                        "beyond": beyond})
    finally:
        env.close()
    return [step_cost_row(task, name, settings[name], steps[name]) for name in settings]


def step_cost_row(task: str, name: str, overrides: dict, steps: list[dict]) -> dict:
    arm = [s for s in steps if s["kind"] == "arm"]

    def mean(rows, key):
        return round(float(np.mean([r[key] for r in rows])), 3) if rows else None

    return {"task": task, "setting": name, "overrides": overrides, "steps": len(steps), "step_ms": mean(steps, "ms"),
            "step_cpu_ms": mean(steps, "cpu_ms"), "arm_steps": len(arm), "arm_step_ms": mean(arm, "ms"),
            "arm_plan_ms": mean(arm, "plan_ms"), "arm_plan_rate": mean(arm, "ok"),
            "arm_beyond_reach": mean(arm, "beyond"), "planned_beyond_reach": sum(s["beyond"] and s["ok"] for s in arm)}


# ------------------------------------------------------------------------------ oracle figures
def oracle_figures(task: str, overrides: dict, episodes: int = 50, seed: int = 0, image_size: int = 128,
                   arm_collision: bool = True, episode_steps: int | None = None) -> dict:
    """The task oracle's ``relmogen oracle`` figures (``subgoal-r``, RRT-Connect for base and arm)
    under a setting, with the CPU seconds of the run."""
    from relmogen.agents.oracles import make_policy

    start = time.process_time()
    env = RelmogenEnv(task=task, control="subgoal-r", image_size=image_size, arm_collision=arm_collision,
                      episode_steps=episode_steps)
    try:
        set_arm_settings(env, overrides)
        agent = make_policy("oracle", env)
        records = run_episodes(env, agent.act, episodes, seed, quiet=True, on_reset=agent.reset)
    finally:
        env.close()
    return {"task": task, "overrides": overrides, "episodes": episodes, **aggregate(records),
            "cpu_s": round(time.process_time() - start, 1)}


# ------------------------------------------------------------------------------ before the door
def door_front_cases(env: RelmogenEnv, count: int, seed: int = 0) -> list[tuple[np.ndarray, float, np.ndarray]]:
    """(base xy, yaw, point) of arm subgoals before PushDoorNav's closed door: the base 0.4-1.0 m
    before the push bar (lateral offset up to 0.6 m, yaw within 0.5 rad of facing it), the point
    a uniform random pixel of the camera image that sees something within the arm's reach."""
    rng, door = np.random.default_rng(seed), env.task.door
    normal = np.asarray(env.task.doorway.normal)
    arm = env.control.mg.arm
    found = []
    while len(found) < count:
        bar = door.face_point(0.45, door.bar_height)
        base = bar[:2] - rng.uniform(0.4, 1.0) * normal + rng.uniform(-0.6, 0.6) * door.closed_direction
        yaw = float(np.arctan2(*(bar[:2] - base)[::-1])) + rng.uniform(-0.5, 0.5)
        col, row = (int(v) for v in rng.integers(0, env.camera.intrinsics.width, 2))
        env.robot.set_base_pose(base[0], base[1], yaw)
        env.robot.set_joint_positions(env.robot.arm_joint_indices, arm.default_config)
        frame = env.camera.capture(*env.robot.camera_pose())
        if frame.has_point(row, col):
            point = env.camera.pixel_to_world(frame, col, row)
            if within_arm_reach(env, point[None])[0]:
                found.append((base, yaw, point))
    return found


def door_front_plan_rates(settings: dict[str, dict], trials: int = 80, seed: int = 0,
                          image_size: int = 64) -> list[dict]:
    """Per setting: of the same ``trials`` door-front arm subgoals, how many one IK + plan attempt
    (RRT-Connect) planned, with the pushed body (the door) exempt as far as the setting's
    ``target_penetration_allowance``; and the failure reasons."""
    env = RelmogenEnv(task="PushDoorNav", control="subgoal-r", image_size=image_size)
    rows = []
    try:
        env.reset(seed=3)
        cases = door_front_cases(env, trials, seed)
        arm_settings = ArmSettings(env)
        for name, overrides in settings.items():
            arm_settings.apply(overrides)
            arm = env.control.mg.arm
            rng, planned, reasons = np.random.default_rng(1), 0, collections.Counter()
            for base, yaw, point in cases:
                env.robot.set_base_pose(base[0], base[1], yaw)
                env.robot.set_joint_positions(env.robot.arm_joint_indices, arm.default_config)
                arm.checker.target_body = arm.body_at(point)
                try:
                    ik = arm.solve_ik(point, rng)
                    plan = arm.plan(ik.config, rng) if ik.config is not None else None
                finally:
                    arm.checker.target_body = None
                if plan is not None and plan.success:
                    planned += 1
                else:
                    reasons[ik.reason if plan is None else f"plan: {plan.reason}"] += 1
            rows.append({"setting": name, "overrides": overrides, "trials": len(cases), "planned": planned,
                         "plan_rate": round(planned / len(cases), 3), "failures": dict(reasons)})
    finally:
        env.close()
    return rows


# ------------------------------------------------------------------------------ IK collisions
def body_name(env: RelmogenEnv, body: int) -> str:
    """``floor``, ``door`` (the door tasks' door), else the body's URDF name or ``body<id>``."""
    if body == env.scene.floor_body_id:
        return "floor"
    door = getattr(env.task, "door", None)
    if door is not None and body == door.body:
        return "door"
    return p.getBodyInfo(body, physicsClientId=env.world.client)[1].decode() or f"body{body}"


def contacts_at_ik_solution(env: RelmogenEnv, target: np.ndarray, rng: np.random.Generator,
                            attempts: int = 20) -> list[tuple[str, str]] | None:
    """(robot link, other body) pairs in contact at an IK solution for ``target`` found without
    the collision check (None if IK finds none), the wheels' and casters' floor contacts left
    out; the robot's joints are restored."""
    arm, robot, client = env.control.mg.arm, env.robot, env.world.client
    config = env.control.mg.arm.config
    saved = robot.joint_state_vector()
    solution = arm.ik_solver.solve(target, rng, config.ik_iterations, attempts, config.ik_tolerance, None, True)
    if solution.config is None:
        return None
    try:
        robot.set_joint_positions(robot.arm_joint_indices, solution.config)
        p.performCollisionDetection(physicsClientId=client)
        floor_links = set(robot.floor_contact_link_indices)
        hits = {(robot.link_names[c[3]], body_name(env, c[2]))
                for c in p.getContactPoints(bodyA=robot.robot_id, physicsClientId=client)
                if c[8] < 0.0 and c[2] != robot.robot_id
                and not (c[3] in floor_links and c[2] == env.scene.floor_body_id)}
    finally:
        arm.ik_solver.restore(saved)
    return sorted(hits)


class IKCollisionRecorder(FrameRecorder):
    """``run_episode``'s recorder: after each arm subgoal whose every IK solution collided, what
    an unchecked solution touches (the world is as before the step: the no-op moved nothing)."""

    REASON = "IK solution in collision"

    def __init__(self) -> None:
        super().__init__()
        self.cases: list[dict] = []
        self.rng = np.random.default_rng(0)

    def start(self, env, obs) -> None:
        self.env = env

    def before_step(self, obs, action) -> None:
        self.frame, self.action = self.env.last_frame, action

    def during_step(self) -> None:
        pass

    def after_step(self, obs, reward, info) -> None:
        if info.get("subgoal_type") != "arm" or self.REASON not in (info.get("reason") or ""):
            return
        env, control = self.env, self.env.control
        if hasattr(control, "decode_continuous") and np.ndim(self.action) == 1 and np.size(self.action) == 8:
            _, (row, col, _) = control.decode_continuous(self.action)
        else:
            _, _, i, j = control.decode(int(self.action))
            row, col = control.cell_pixel(i, j)
        target = env.camera.pixel_to_world(self.frame, col, row)
        surface = env.control.mg.arm.body_at(target)
        hits = contacts_at_ik_solution(env, target, self.rng)
        self.cases.append({"target_body": None if surface is None else body_name(env, surface),
                           "height": round(float(target[2]), 3),
                           "distance": round(float(np.linalg.norm(target - env.robot.arm_base_position())), 3),
                           "contacts": hits})


def ik_collisions(policy: Path, seeds: list[int], checkpoint: str = "latest", **env_overrides) -> dict:
    """For each arm subgoal of the policy's greedy episodes (arm collision checking on) that
    failed with every IK solution in collision: the body the point lies on, its height and
    distance from the arm base, and what an unchecked solution touches; and the counts per
    (robot link, body touched, whether it is the subgoal's own surface)."""
    from relmogen.experiments.loading import load_trained

    trained = load_trained(Path(policy), checkpoint, device="cpu")
    env = trained.make_env(**env_overrides).unwrapped
    act = trained.policy(env)
    recorder = IKCollisionRecorder()
    successes = []
    try:
        for seed in seeds:
            successes.append(bool(run_episode(env, act, seed, recorder=recorder).metrics.get("success")))
    finally:
        env.close()
    counts = collections.Counter((link, body, body == case["target_body"])
                                 for case in recorder.cases for link, body in case["contacts"] or [])
    return {"episodes": len(seeds), "success_rate": float(np.mean(successes)) if successes else None,
            "cases": recorder.cases,
            "counts": [{"link": link, "body": body, "is_target_body": own, "count": n}
                       for (link, body, own), n in counts.most_common()]}

