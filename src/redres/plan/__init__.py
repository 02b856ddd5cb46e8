"""Global redundancy resolution along a prescribed path: dynamic programming over the
self-motion (:mod:`redres.plan.planner`), on the grid of IK solutions of
:mod:`redres.plan.grid`.

``rr.plan_path(robot, path, dt=..., objective="joint_limit_margin")`` returns a
:class:`PathPlan`: the joint path at ``t = k·dt``, its objective, whether one exists, and
the node counts and topology of the grid (:class:`PlanStats`).
"""

from __future__ import annotations

from .clearance import clearances
from .grid import PathGrid, build_grid, path_poses
from .planner import OBJECTIVES, PathPlan, PlanStats, plan_path, solve_grid

__all__ = [
    "OBJECTIVES",
    "PathGrid",
    "PathPlan",
    "PlanStats",
    "build_grid",
    "clearances",
    "path_poses",
    "plan_path",
    "solve_grid",
]
