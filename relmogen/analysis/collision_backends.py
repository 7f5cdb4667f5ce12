"""The arm's collision backends side by side: the same random arm configurations in a task's
scene, answered by each backend inside one IK-solve-like block (``other_joints_held``), with the
agreement and the CPU time per query.

    relmogen analyse collision-backends [--tasks T ...] [--configurations 600] [--seeds 0 1 2] [--json]

Half the configurations are uniform within the joint limits, half near the pose the episode
starts in (normal, 0.4 rad / m), where the table, the door and the robot's own body are close.
"""

from __future__ import annotations

import time

import numpy as np

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.motion_generation.arm import COLLISION_BACKENDS, ArmCollisionChecker

ARM_TASKS = ("TabletopReachM", "PushDoorNav", "ButtonDoorNav", "InteractiveObstaclesNav", "ArrangeKitchenMM",
             "ArrangeChairMM")
NEAR_START_SPREAD = 0.4


def random_configurations(checker: ArmCollisionChecker, start: np.ndarray, count: int,
                          rng: np.random.Generator) -> np.ndarray:
    """``count`` planning-joint configurations: half uniform, half near ``start`` (clipped to the limits)."""
    uniform = rng.uniform(checker.lower, checker.upper, (count // 2, len(start)))
    near = np.clip(start + rng.normal(0.0, NEAR_START_SPREAD, (count - count // 2, len(start))),
                   checker.lower, checker.upper)
    return np.concatenate([uniform, near])


def answers_and_cpu(checker: ArmCollisionChecker, env: RelmogenEnv, configurations: np.ndarray) -> tuple[np.ndarray, float]:
    """Each configuration's verdict (True: collision) and the CPU seconds of the queries; the
    planning joints are restored."""
    saved = env.robot.joint_state_vector()[0]
    with checker.other_joints_held():
        start = time.process_time()
        verdicts = np.array([checker(q) for q in configurations])
        seconds = time.process_time() - start
    env.robot.set_joint_positions(env.robot.arm_joint_indices, saved)
    return verdicts, seconds


def backend_agreement(task: str, configurations: int = 600, seed: int = 0, image_size: int = 32) -> dict:
    """One episode start of ``task``: each backend's collision rate and microseconds per query,
    the share of equal answers and the count of each kind of difference."""
    env = RelmogenEnv(task=task, control="subgoal-r", image_size=image_size)
    try:
        env.reset(seed=seed)
        arm = env.control.mg.arm
        checkers = {backend: ArmCollisionChecker(env.world.client, env.robot, arm.config.gripper_penetration_allowance,
                                                 arm.config.target_penetration_allowance, backend=backend)
                    for backend in COLLISION_BACKENDS}
        queries = random_configurations(checkers["pybullet"], env.robot.joint_state_vector()[0], configurations,
                                        np.random.default_rng(seed))
        results = {backend: answers_and_cpu(checker, env, queries) for backend, checker in checkers.items()}
    finally:
        env.close()
    pybullet, coal = results["pybullet"][0], results["coal"][0]
    row = {"task": task, "seed": seed, "configurations": len(queries)}
    for backend, (verdicts, seconds) in results.items():
        row[f"{backend}_collision_rate"] = float(verdicts.mean())
        row[f"{backend}_us_per_query"] = 1e6 * seconds / len(queries)
    row.update(agreement=float(np.mean(pybullet == coal)), pybullet_only=int(np.sum(pybullet & ~coal)),
               coal_only=int(np.sum(coal & ~pybullet)))
    return row


def agreement_rows(tasks: list[str], configurations: int, seeds: list[int]) -> tuple[list[dict], dict]:
    """A row per task and seed, and the range of the agreement and of the speed-up over them."""
    rows = [backend_agreement(task, configurations, seed) for task in tasks for seed in seeds]
    speedups = [row["pybullet_us_per_query"] / row["coal_us_per_query"] for row in rows]
    summary = {"agreement_min": min(row["agreement"] for row in rows), "agreement_max": max(row["agreement"] for row in rows),
               "coal_only_total": sum(row["coal_only"] for row in rows),
               "speedup_min": min(speedups), "speedup_max": max(speedups)}
    return rows, summary
