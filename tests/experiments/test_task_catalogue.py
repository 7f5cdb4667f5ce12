"""The task catalogue reads each task's metrics from the task itself."""

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.task_catalogue import task_catalogue, task_evaluation_keys, task_metric_names
from relmogen.tasks import TASKS


def test_the_catalogue_has_a_row_per_task_with_the_class_attributes():
    rows = task_catalogue()
    assert [row["task"] for row in rows] == sorted(TASKS)
    for row in rows:
        cls = TASKS[row["task"]]
        assert row["scene"] == cls.scene_kind and row["subgoal_parts"] == list(cls.subgoal_parts)
        assert row["episode_steps"] == {"joint": cls.joint_steps, "subgoal-r": cls.subgoal_steps,
                                        "subgoal-d": cls.subgoal_steps}


def test_metric_names_are_the_keys_an_episode_reports():
    env = RelmogenEnv(task="ArrangeKitchenMM", control="subgoal-r", image_size=16, episode_steps=1)
    try:
        env.reset(seed=0)
        *_, info = env.step(env.action_space.sample())
    finally:
        env.close()
    assert task_metric_names("ArrangeKitchenMM") == tuple(info["metrics"])
    assert task_evaluation_keys("PointNav")[:2] == ("success_rate", "spl")
