"""Scripted subgoal policies with privileged state, one module per task (auto-imported)."""

import importlib
import pkgutil

from relmogen.agents.oracles.base import (
    ORACLES,
    Oracle,
    RandomSubgoals,
    make_policy,
    register_oracle,
)

for _module in pkgutil.iter_modules(__path__):
    if _module.name != "base":
        importlib.import_module(f"{__name__}.{_module.name}")

__all__ = ["ORACLES", "Oracle", "RandomSubgoals", "make_policy", "register_oracle"]
