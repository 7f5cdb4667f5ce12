"""Tasks: one file per task, registered by name (the gymnasium ids follow from the names)."""

from relmogen.tasks.base import TASKS, Task, TaskContext, register_task, task_class
from relmogen.tasks import point_nav, tabletop_reach  # noqa: F401  (registration)

__all__ = ["TASKS", "Task", "TaskContext", "register_task", "task_class"]
