"""Motion generation: sampling-based planners (pybullet-planning / OMPL) and the base planner."""

from relmogen.motion_generation.base_planner import (
    FETCH_FOOTPRINT_RADIUS,
    BasePlanResult,
    FootprintChecker,
    make_base_planner,
    plan_base,
)
from relmogen.motion_generation.planners import (
    BACKENDS,
    PlanningProblem,
    PlanResult,
    Planner,
    make_planner,
)

__all__ = [
    "BACKENDS",
    "FETCH_FOOTPRINT_RADIUS",
    "BasePlanResult",
    "FootprintChecker",
    "PlanResult",
    "PlanningProblem",
    "Planner",
    "make_base_planner",
    "make_planner",
    "plan_base",
]
