"""``relmogen tasks``: every registered task with its scene kind, metrics and episode lengths.

The metrics are the keys a task's ``metrics()`` returns: each task is built once in a bare
PyBullet world (no camera, no control) and reset, which takes well under a second for all of
them. The report uses the same keys to show each task's own metrics only.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from relmogen.tasks import TASKS, TaskContext, task_class

# The project-wide evaluation key of a task metric, where the two differ (rollout.aggregate).
EVALUATION_KEY = {"success": "success_rate"}


@lru_cache(maxsize=None)
def task_metric_names(task: str) -> tuple[str, ...]:
    """The keys of ``task``'s episode metrics, in the order its ``metrics()`` gives them."""
    from relmogen.robots.robot import Robot
    from relmogen.robots.spec import load_spec
    from relmogen.scenes import make_scene
    from relmogen.simulation.world import World

    cls = task_class(task)
    world = World()
    try:
        scene = make_scene(f"{cls.scene_kind}_A", world.client, seed=0)
        instance = cls(TaskContext(world, scene, Robot(world.client, load_spec("fetch"))))
        instance.load()
        instance.reset(np.random.default_rng(0))
        instance.after_reset()
        return tuple(instance.metrics())
    finally:
        world.close()


def task_evaluation_keys(task: str) -> tuple[str, ...]:
    """``task_metric_names`` with the evaluation keys (``success`` -> ``success_rate``)."""
    return tuple(EVALUATION_KEY.get(name, name) for name in task_metric_names(task))


def task_catalogue() -> list[dict]:
    """A row per task: name, Gymnasium id, scene kind, subgoal parts, metrics and the episode
    length of each control (steps of 0.1 s for ``joint``, subgoals for the subgoal controls)."""
    rows = []
    for name in sorted(TASKS):
        cls = TASKS[name]
        rows.append({"task": name, "id": f"relmogen/{name}-v0", "scene": cls.scene_kind,
                     "subgoal_parts": list(cls.subgoal_parts), "metrics": list(task_metric_names(name)),
                     "episode_steps": {"joint": cls.joint_steps, "subgoal-r": cls.subgoal_steps,
                                       "subgoal-d": cls.subgoal_steps}})
    return rows
