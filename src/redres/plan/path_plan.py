"""The result of planning a path: :class:`PathPlan` (the joint path, its objective, the
plan at any time ``t``) and :class:`PlanStats` (what the dynamic programming saw: node
counts, topology, time)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .._validate import FloatArray, as_scalar
from ..errors import InvalidParameterError
from .grid import PathGrid

__all__ = ["PathPlan", "PlanStats"]


@dataclass(frozen=True)
class PlanStats:
    """What the DP saw.

    Attributes:
        nodes: grid nodes ``K·P·B``. feasible_nodes: within the limits.
        feasible_per_sample: ``(K,)`` feasible nodes at each sample.
        reachable_nodes: reached by an admissible path from the start.
        traversable_nodes: on some complete admissible path (start to end).
        pairs_checked: node pairs the transition test ran on (after pruning).
        transitions: admissible transitions among them (with ``qdd_max``: every
            velocity transition between feasible nodes, the states of the DP).
        components: connected components of the traversable nodes (0: no path).
        first_infeasible: the first sample without a feasible node, or None.
        first_unreachable: the first sample no admissible path from the start reaches,
            or None.
        seconds_grid, seconds_dp: wall-clock time of the grid (IK) and of the DP, s.
        colliding_nodes: nodes within the joint limits but closer to an obstacle than
            ``clearance`` (not counted in ``feasible_nodes``).
        edge_pairs_checked, edge_pairs: with acceleration limits, the pairs of
            consecutive transitions ``x_{k−1} → x_k → x_{k+1}`` the acceleration test ran
            on, and those it allowed (0 without).
    """

    nodes: int
    feasible_nodes: int
    feasible_per_sample: NDArray[np.int64] = field(repr=False)
    reachable_nodes: int
    traversable_nodes: int
    pairs_checked: int
    transitions: int
    components: int
    first_infeasible: int | None
    first_unreachable: int | None
    seconds_grid: float
    seconds_dp: float
    colliding_nodes: int = 0
    edge_pairs_checked: int = 0
    edge_pairs: int = 0


@dataclass(frozen=True)
class PathPlan:
    """The optimal joint path of :func:`plan_path` or :func:`solve_grid`.

    Attributes:
        q: ``(K, n)`` the configuration at each sample ``t = k·dt``, rad (NaN rows when
            not ``feasible``).
        t: ``(K,)`` s.
        objective: the optimum (rad for the margin and the path length; ``s·m³`` for
            the manipulability integral of a 6-row task; your cost's unit); NaN when not
            ``feasible``.
        objective_name: which objective.
        feasible: an admissible path exists.
        parameter: the redundancy parameter of the grid.
        values: ``(K,)`` the parameter's value chosen at each sample, rad.
        branch: ``(K,)`` the branch chosen at each sample.
        min_margin: the smallest joint-limit margin along ``q``, rad.
        path_length: ``Σ ‖q_{k+1} − q_k‖``, rad.
        dt: s between samples. qd_max: ``(n,)`` the velocity limits planned with, rad/s.
        stats: :class:`PlanStats`.
        grid: the :class:`~redres.plan.grid.PathGrid` planned over (its ``feasible``
            also clear of the obstacles, when given).
        min_clearance: the smallest clearance to the obstacles along ``q``, m (NaN
            without obstacles or when not ``feasible``).
        qdd_max: ``(n,)`` the acceleration limits planned with, rad/s², or None (none).
    """

    q: FloatArray
    t: FloatArray
    objective: float
    objective_name: str
    feasible: bool
    parameter: str
    values: FloatArray
    branch: NDArray[np.int64]
    min_margin: float
    path_length: float
    dt: float
    qd_max: FloatArray
    stats: PlanStats
    grid: PathGrid = field(repr=False)
    min_clearance: float = math.nan
    qdd_max: FloatArray | None = None

    @property
    def speed_ratio(self) -> float:
        """The largest ``|q_{k+1} − q_k| / (q̇_max·dt)`` over joints and steps (≤ 1 by
        construction; NaN when not ``feasible``)."""
        if not self.feasible or len(self.q) < 2:
            return math.nan if not self.feasible else 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.abs(np.diff(self.q, axis=0)) / (self.qd_max * self.dt)
        return float(np.nanmax(np.where(np.isfinite(self.qd_max), ratio, 0.0)))

    @property
    def acceleration_ratio(self) -> float:
        """The largest ``|q_{k+1} − 2 q_k + q_{k−1}| / (q̈_max·dt²)`` over joints and
        samples: the central finite-difference acceleration against ``qdd_max`` (≤ 1 by
        construction; NaN without ``qdd_max`` or when not ``feasible``)."""
        if self.qdd_max is None or not self.feasible:
            return math.nan
        if len(self.q) < 3:
            return 0.0
        second = np.abs(self.q[2:] - 2.0 * self.q[1:-1] + self.q[:-2])
        return float(np.max(second / (self.qdd_max * self.dt * self.dt)))

    def at(self, t: float) -> tuple[FloatArray, FloatArray]:
        """The plan interpolated linearly at time ``t`` (s, clipped to the plan's span):
        ``(q (n,), qd (n,))``. Between samples the velocity is the constant
        ``(q_{k+1} − q_k)/dt``, within ``qd_max`` by construction, and ``q`` a convex
        combination of two configurations within the limits, so within them too."""
        if not self.feasible:
            raise InvalidParameterError("the plan is not feasible: it has no joint path")
        t = as_scalar(t, "t")
        K = len(self.q)
        if K == 1:
            return self.q[0].copy(), np.zeros_like(self.q[0])
        x = min(max(t / self.dt, 0.0), K - 1.0)
        k = min(int(x), K - 2)
        qd = (self.q[k + 1] - self.q[k]) / self.dt
        return self.q[k] + (x - k) * (self.q[k + 1] - self.q[k]), qd
