"""Gymnasium registration: ``relmogen/<TaskName>-v0`` for every registered task."""

import gymnasium as gym

from relmogen.tasks import TASKS

ENV_IDS = [f"relmogen/{name}-v0" for name in TASKS]


def register_envs() -> None:
    for name in TASKS:
        env_id = f"relmogen/{name}-v0"
        if env_id not in gym.registry:
            gym.register(env_id, entry_point="relmogen.envs.relmogen_env:RelmogenEnv", kwargs={"task": name})


register_envs()
