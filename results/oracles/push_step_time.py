"""CPU ms per uniform random subgoal-r step on PushDoorNav with the push's physics sub-steps
given: ``python results/oracles/push_step_time.py SUB_STEPS [STEPS]`` (the training setting:
image 64, arm collision checking off, nearest_free base goals, no-op cost, subgoal feedback)."""

import sys
import time
from dataclasses import replace

import numpy as np

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.motion_generation.generator import MotionGenerator


def main(sub_steps: int, steps: int = 300) -> float:
    original = MotionGenerator._arm_config
    MotionGenerator._arm_config = lambda self: replace(original(self), push_sub_steps=sub_steps)
    env = RelmogenEnv(task="PushDoorNav", control="subgoal-r", image_size=64, base_goal="nearest_free",
                      noop_cost=0.1, arm_collision=False, subgoal_feedback=True)
    rng = np.random.default_rng(0)
    env.reset(seed=0)
    start = time.process_time()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        if terminated or truncated:
            env.reset(seed=int(rng.integers(1 << 30)))
    return (time.process_time() - start) / steps * 1000.0


if __name__ == "__main__":
    sub_steps = int(sys.argv[1])
    print(f"push_sub_steps {sub_steps}: {main(sub_steps, int(sys.argv[2]) if len(sys.argv) > 2 else 300):.2f} ms")
