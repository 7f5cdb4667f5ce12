"""Tasks: one file per task, registered by name (the gymnasium ids follow from the names).

Every module in this package is imported here, so a new task file registers itself.
"""

import importlib
import pkgutil

from relmogen.tasks.base import TASKS, Task, TaskContext, register_task, task_class

_SHARED = {"base", "terms", "navigation"}
for _module in pkgutil.iter_modules(__path__):
    if _module.name not in _SHARED:
        importlib.import_module(f"{__name__}.{_module.name}")

__all__ = ["TASKS", "Task", "TaskContext", "register_task", "task_class"]
