"""Why do arm subgoals fail? Two diagnostics behind results/movo/README.md.

``reasons ROBOT TASK EPISODES``: the task's oracle (``subgoal-r``, 64 px, seeds 0..) and the
reason of every arm subgoal it sends, counted.

``ik ROBOT``: TabletopReachM, seeds 0-5: 15 IK solutions per marker (2 cm above it; the first from
the current pose, then random seeds) without the collision check, then what each collides with
(world contacts deeper than the gripper allowance, robot link pairs), counted.

    python results/movo/diagnose_arm.py reasons movo PushDoorNav 5
    python results/movo/diagnose_arm.py ik movo
"""

from __future__ import annotations

import collections
import sys

import numpy as np
import pybullet as p

from relmogen.agents.oracles import make_policy
from relmogen.envs.relmogen_env import RelmogenEnv


def reasons(robot: str, task: str, episodes: int) -> collections.Counter:
    env = RelmogenEnv(task=task, control="subgoal-r", robot=robot, image_size=64)
    agent, counts = make_policy("oracle", env), collections.Counter()
    for episode in range(episodes):
        obs, _ = env.reset(seed=episode)
        agent.reset()
        done = False
        while not done:
            obs, _, terminated, truncated, info = env.step(agent.act(obs))
            done = terminated or truncated
            if info.get("subgoal_type") == "arm":
                counts[info.get("reason")] += 1
    env.close()
    return counts


def ik_collisions(robot_name: str) -> tuple[int, int, collections.Counter]:
    env = RelmogenEnv(task="TabletopReachM", control="subgoal-r", robot=robot_name, image_size=64)
    arm, robot = env.control.mg.arm, env.robot
    checker, client = arm.checker, env.world.client
    hits, solutions, free, rng = collections.Counter(), 0, 0, np.random.default_rng(0)
    for episode in range(6):
        env.reset(seed=episode)
        target, saved = env.task.goal + np.array([0.0, 0.0, 0.02]), robot.joint_state_vector()
        for k in range(15):
            result = arm.ik_solver.solve(target, rng, 100, 1, 0.05, None, from_current=k == 0)
            if result.config is None:
                continue
            solutions += 1
            robot.set_joint_positions(checker.joints, result.config)
            p.performCollisionDetection(physicsClientId=client)
            bad = False
            for contact in p.getContactPoints(bodyA=robot.robot_id, physicsClientId=client):
                threshold = checker._world_thresholds.get(contact[3])
                if threshold is not None and contact[2] != robot.robot_id and contact[8] < threshold:
                    hits[("world", robot.link_names[contact[3]])] += 1
                    bad = True
            boxes = np.array([p.getAABB(robot.robot_id, link, physicsClientId=client) for link in checker._aabb_links])
            for a, b in checker._self_pairs_with_overlapping_boxes(boxes):
                if checker._links_touch(a, b):
                    hits[("self", robot.link_names[a], robot.link_names[b])] += 1
                    bad = True
            free += not bad
        arm.ik_solver.restore(saved)
    env.close()
    return solutions, free, hits


if __name__ == "__main__":
    if sys.argv[1] == "reasons":
        print(sys.argv[2:], reasons(sys.argv[2], sys.argv[3], int(sys.argv[4])).most_common())
    else:
        solutions, free, hits = ik_collisions(sys.argv[2])
        print(sys.argv[2], f"{solutions} IK solutions, {free} collision-free", hits.most_common())
