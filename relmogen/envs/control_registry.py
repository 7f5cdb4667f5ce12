"""The controls ``RelmogenEnv(control=NAME)`` can build, by name.

The registry sits above the control modules, so imports run one way: ``relmogen_env`` ->
``control_registry`` -> ``subgoal_controls`` -> ``controls``. The control modules name
``RelmogenEnv`` for type checking only.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from relmogen.envs.controls import Control, JointVelocityControl
from relmogen.envs.subgoal_controls import SubgoalDControl, SubgoalRControl

if TYPE_CHECKING:
    from relmogen.envs.relmogen_env import RelmogenEnv

CONTROLS: dict[str, type[Control]] = {
    "joint": JointVelocityControl,
    "subgoal-r": SubgoalRControl,
    "subgoal-d": SubgoalDControl,
}
CONTROL_NAMES = tuple(CONTROLS)


def make_control(name: str, env: RelmogenEnv, **options: Any) -> Control:
    """The control ``name`` of ``env``; ValueError for an unknown name or options ``joint`` does not take."""
    if name not in CONTROLS:
        raise ValueError(f"unknown control {name!r}; valid controls: {', '.join(CONTROL_NAMES)}")
    if name == "joint" and options:
        raise ValueError(f"control 'joint' takes no options, got {sorted(options)}")
    return CONTROLS[name](env, **options)
