"""What collides when every IK solution of an arm subgoal is in collision: for each such subgoal of
a run's best checkpoint (deterministic, checking on), one IK solution found without the check, the
robot links in contact at it (with the body they touch; '' is the door, link0 the floor) and the
target's height and distance from the arm base; at the end, the counts per (link, body, is the
body the subgoal's surface).

    python ik_collisions.py RUN SEED [SEED ...] > ik_collisions_seedN.txt
"""
import collections, sys
import numpy as np, pybullet as p
from pathlib import Path
from relmogen.experiments.evaluate import load_policy, policy_act
from relmogen.experiments.train import env_kwargs
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.rollout import run_episode
from relmogen.motion_generation import arm as arm_module

stats = collections.Counter()
orig = arm_module.ArmMotion.solve_ik
def solve_ik(self, target, rng, from_current=True):
    r = orig(self, target, rng, from_current)
    if r.reason == "IK solution in collision":
        saved = self.robot.joint_state_vector()
        q = self.ik_solver.solve(target, rng, 100, 20, 0.05, None, True).config
        self.robot.set_joint_positions(self.robot.arm_joint_indices, q)
        p.performCollisionDetection(physicsClientId=self.client)
        hits = set()
        for c in p.getContactPoints(bodyA=self.robot.robot_id, physicsClientId=self.client):
            if c[8] < -0.0 and c[2] != self.robot.robot_id:
                link = p.getJointInfo(self.robot.robot_id, c[3], physicsClientId=self.client)[12].decode()
                other = p.getBodyInfo(c[2], physicsClientId=self.client)[1].decode()
                hits.add((link, other, c[4]))
        self.ik_solver.restore(saved)
        tb = self.body_at(np.asarray(target))
        tname = p.getBodyInfo(tb, physicsClientId=self.client)[1].decode() if tb is not None else None
        dist = np.linalg.norm(np.asarray(target) - self.robot.arm_base_position())
        print("COLLIDE target_on", tname, "z=%.2f d=%.2f" % (target[2], dist), sorted(hits), flush=True)
        for h in hits: stats[(h[0], h[1], h[1] == tname)] += 1
    return r
arm_module.ArmMotion.solve_ik = solve_ik
run, seeds = Path(sys.argv[1]), [int(s) for s in sys.argv[2:]]
model, config, _ = load_policy(run, checkpoint="best")
env = RelmogenEnv(**env_kwargs(config, True, None, None, None))
act = policy_act(model, config, env)
for s in seeds:
    rec = run_episode(env, act, s)
    print("EPISODE", s, rec.metrics.get("success"), flush=True)
print(stats.most_common(20))
