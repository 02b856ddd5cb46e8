"""The globally optimal joint path along a prescribed tool path, by dynamic programming
over the self-motion: ``rr.plan_path``.

Every scheme of :mod:`redres.resolution` is *local*: it picks the joint velocity from the
present state. Along a prescribed path of ``K`` poses the choices form a grid instead
(:mod:`redres.plan.grid`): at sample ``k`` the nodes ``x`` are the IK solutions at ``P``
values of the redundancy parameter on up to 8 branches. A joint path is one node per
sample; it is admissible when every node is feasible (within the joint limits) and every
step respects the velocity limits, ``|q_{k+1} − q_k| ≤ q̇_max·dt`` joint by joint
(a transition between branches is allowed exactly when it passes this test: the check,
not a rule about branches, decides). Over the admissible paths, Bellman's principle
(Ferrentino, Salvioli & Chiacchio, Robotics 10(1):42, 2021, eq. 9) gives the optimum of
an additive cost by the recursion

    V_0(x) = c_0(x),   V_{k+1}(y) = min over admissible x → y of [V_k(x) + e(x, y)] + c_{k+1}(y)

and the path by following the minimising ``x`` back from the best last node. The
objectives:

* ``"joint_limit_margin"``: the largest smallest margin ``m(q) = min_j min(q_j − q_min,j,
  q_max,j − q_j)`` (rad) along the path, a *bottleneck* problem: the same recursion with
  ``(min, max)`` for ``(+, min)``, ``V_{k+1}(y) = min(m(y), max_x V_k(x))``, exact
  because ``min`` is monotone (Pollack, "The maximum capacity through a network",
  Operations Research 8(5), 1960). Many paths share the optimum; among them the plan is
  the shortest (a second pass of the additive recursion over the nodes with
  ``m ≥ V*``);
* ``"obstacle_clearance"``: the largest smallest clearance ``d(q)`` (m) between the
  link capsules and ``obstacles`` (:mod:`redres.plan.clearance`) along the path, the
  same bottleneck recursion with ``d`` for ``m``;
* ``"manipulability"``: the largest integral ``∫ w(q) dt`` of Yoshikawa's ``w =
  √det(J Jᵀ)`` (trapezoid rule over the samples; ``c = −w·h_k``);
* ``"path_length"``: the shortest ``Σ ‖q_{k+1} − q_k‖`` (rad; ``e`` that norm);
* a callable ``cost(q)`` on ``(M, n)`` configurations returning ``(M,)``: the smallest
  ``Σ_k cost(q_k)``.

Obstacles. Given ``obstacles``, a node whose clearance is below ``clearance`` (m,
default 0: no penetration) is infeasible, whatever the objective, as a node outside the
joint limits is (clearance at the samples only: between two of them each joint moves at
most ``q̇_max·dt``).

The additive objectives are summed in path order, ``(V_k + e) + c``, so that a sum over
one path computed in that order equals the DP's value to the last bit.

Topology. The first sample with no feasible node, else the first that no admissible
path from the start reaches, tells where a path is impossible. Of the nodes that lie on
some complete admissible path (reached from the start *and* leading to the end), the
connected components under the transitions are the pieces of the feasible region a
robot cannot move between along this path (:attr:`PlanStats.components`): a local
scheme stays in the piece it starts in.

Execution. :meth:`PathPlan.at` interpolates the plan linearly between samples: within
the joint limits and ``qd_max`` by construction. A :class:`~redres.control.Controller`
tracks it with the path as its frame task and the plan's ``q(t)`` as a posture level
below it (``PriorityScheme([PostureTask(...)])``, ``q_ref`` set each period: see
``examples/18_global_plan.py``).

The transition check over all pairs of consecutive samples' nodes is the hot loop
(``(P·B)²`` pairs per sample); :mod:`redres.plan._kernels` searches, for each node, only
the window of the next sample's nodes sorted by the joint that separates them best,
which is exact (an admissible pair is inside the window) and leaves tens of candidates
per node instead of thousands.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from .. import _compile
from .._validate import FloatArray, as_gains, as_scalar, as_vector
from ..control.trajectories import Trajectory
from ..errors import InvalidParameterError, NonFiniteError, ShapeError
from .clearance import KeepOut, screen
from .grid import Parameter, PathGrid, build_grid, parameter_values, path_poses

if TYPE_CHECKING:
    from ..objectives import Obstacle
    from ..robot import Capsule, Robot

__all__ = ["DT", "KERNELS", "OBJECTIVES", "PathPlan", "PlanStats", "plan_path", "solve_grid"]

#: The DP kernels (:mod:`redres.plan._kernels`). Cold (2026-12-07, 2 shared cores, load
#: 3.0): a first 2-sample plan 4.3, 4.6, 8.5 s on an empty cache; warm 0.7, 0.7, 1.2 s.
KERNELS = _compile.KernelGroup("plan", ("redres.plan._kernels",), cold_seconds=5.0)

Objective = Literal["joint_limit_margin", "obstacle_clearance", "manipulability", "path_length"]
OBJECTIVES = ("joint_limit_margin", "obstacle_clearance", "manipulability", "path_length")
#: The max-min objectives (the bottleneck recursion).
_BOTTLENECK = ("joint_limit_margin", "obstacle_clearance")
#: The default time between the samples of a trajectory, s.
DT = 0.01
#: How far ``q0`` may be from its node on the grid, rad (it is on the grid by
#: construction: the parameter's values are shifted to its value).
Q0_TOL = 1e-6
#: A grid with at most this many feasible nodes runs through the kernels' plain-Python
#: twin while they compile behind; a larger one waits for the compilation.
_PLAIN_NODES = 20_000


@dataclass(frozen=True)
class PlanStats:
    """What the DP saw.

    Attributes:
        nodes: grid nodes ``K·P·B``. feasible_nodes: within the limits.
        feasible_per_sample: ``(K,)`` feasible nodes at each sample.
        reachable_nodes: reached by an admissible path from the start.
        traversable_nodes: on some complete admissible path (start to end).
        pairs_checked: node pairs the transition test ran on (after pruning).
        transitions: admissible transitions among them.
        components: connected components of the traversable nodes (0: no path).
        first_infeasible: the first sample without a feasible node, or None.
        first_unreachable: the first sample no admissible path from the start reaches,
            or None.
        seconds_grid, seconds_dp: wall-clock time of the grid (IK) and of the DP, s.
        colliding_nodes: nodes within the joint limits but closer to an obstacle than
            ``clearance`` (not counted in ``feasible_nodes``).
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

    @property
    def speed_ratio(self) -> float:
        """The largest ``|q_{k+1} − q_k| / (q̇_max·dt)`` over joints and steps (≤ 1 by
        construction; NaN when not ``feasible``)."""
        if not self.feasible or len(self.q) < 2:
            return math.nan if not self.feasible else 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.abs(np.diff(self.q, axis=0)) / (self.qd_max * self.dt)
        return float(np.nanmax(np.where(np.isfinite(self.qd_max), ratio, 0.0)))

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


def plan_path(
    robot: Robot,
    path: Any,
    *,
    dt: float | None = None,
    parameter: Parameter | None = None,
    resolution: int = 90,
    objective: Objective | Callable[[FloatArray], Any] = "joint_limit_margin",
    qd_max: Any = None,
    q0: Any = None,
    frame: str | None = None,
    obstacles: Sequence[Obstacle] | None = None,
    clearance: float = 0.0,
    capsules: Sequence[Capsule] | None = None,
) -> PathPlan:
    """The globally optimal joint path of a 7-DOF arm along a tool path (module
    docstring).

    Args:
        robot: a 7R arm with a closed form (:mod:`redres.plan.grid`).
        path: a :class:`~redres.control.trajectories.Trajectory` (sampled at ``t = k·dt``
            up to its duration) or poses of ``frame`` ``(K, 4, 4)`` (``t = k·dt``).
        dt: s between samples (> 0): with ``qd_max`` it bounds each step. Default
            :data:`DT` for a trajectory; required for poses.
        parameter: ``"arm_angle"`` (S-R-S arms; the default there) or ``"q7"`` (the
            default otherwise).
        resolution: parameter values per sample (≥ 2): over the circle for the arm
            angle, over the joint's range for ``q7``.
        objective: ``"joint_limit_margin"`` (max-min, rad), ``"obstacle_clearance"``
            (max-min, m; needs ``obstacles``), ``"manipulability"``
            (largest integral), ``"path_length"`` (shortest, rad), or a function
            ``cost(q (M, n)) -> (M,)`` whose sum over the samples is minimised.
        qd_max: joint velocity limits, rad/s, a scalar or ``(n,)`` (default the
            robot's).
        q0: the start configuration (default: free). It must put ``frame`` at the
            path's first pose; the parameter's values are shifted so that ``q0`` is a
            node, and the plan starts there.
        frame: the frame on the path (default the robot's tip).
        obstacles: :class:`~redres.objectives.SphereObstacle` and
            :class:`~redres.objectives.CapsuleObstacle` in world coordinates: a node
            closer to one than ``clearance`` is infeasible.
        clearance: the smallest clearance a node may have, m (default 0: touching).
        capsules: the link capsules measured (default ``robot.capsules``).

    Returns:
        The :class:`PathPlan`; ``feasible`` False (with ``stats.first_infeasible`` or
        ``stats.first_unreachable``) when no admissible path exists.

    Raises:
        NotAnalyticError, NotSRSError: no closed form for ``parameter``.
        InvalidParameterError: a bad ``resolution``, ``objective``, ``qd_max``, ``dt``,
            ``obstacles`` or ``clearance``; a ``q0`` that is not on the path's first
            pose; ``"obstacle_clearance"`` without obstacles; no link capsules.
        ShapeError, NonFiniteError: bad poses or ``q0``.
    """
    if parameter is None:
        parameter = _default_parameter(robot, frame)
    if parameter not in ("q7", "arm_angle"):
        raise InvalidParameterError(f"parameter must be 'q7' or 'arm_angle'; got {parameter!r}")
    integer = isinstance(resolution, (int, np.integer)) and not isinstance(resolution, bool)
    if not integer or resolution < 2:
        raise InvalidParameterError(
            f"resolution must be an integer >= 2 (parameter values per sample); got {resolution!r}"
        )
    keep = KeepOut.of(obstacles, clearance, capsules)
    _check_objective(objective, keep)
    if dt is None:
        if not isinstance(path, Trajectory):
            raise InvalidParameterError(
                "dt is required for poses (K, 4, 4): the time between them, s, which with "
                "qd_max bounds each step"
            )
        dt = DT
    began = time.perf_counter()
    poses, t = path_poses(path, dt)
    anchor = start = None
    if q0 is not None:
        q0 = as_vector(q0, "q0", robot.n)
        anchor = float(q0[6]) if parameter == "q7" else _arm_angle(robot, q0)
    values = parameter_values(robot, parameter, int(resolution), len(t), anchor)
    grid = build_grid(robot, poses, t, values, parameter, frame)
    if q0 is not None:
        start = _start_node(grid, q0, anchor)  # type: ignore[arg-type]
    return _solve(robot, grid, objective, float(dt), qd_max, start, frame, keep,
                  time.perf_counter() - began)  # fmt: skip


def solve_grid(
    robot: Robot,
    grid: PathGrid,
    *,
    dt: float,
    objective: Objective | Callable[[FloatArray], Any] = "joint_limit_margin",
    qd_max: Any = None,
    start: tuple[int, int] | None = None,
    frame: str | None = None,
    obstacles: Sequence[Obstacle] | None = None,
    clearance: float = 0.0,
    capsules: Sequence[Capsule] | None = None,
) -> PathPlan:
    """:func:`plan_path` over a grid of your own (a planar arm's closed form, another
    parametrisation): the same DP, objectives, obstacles and result. ``start``: the node
    ``(value index, branch)`` of the first sample the plan must start at (default:
    free)."""
    keep = KeepOut.of(obstacles, clearance, capsules)
    _check_objective(objective, keep)
    dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
    if start is not None:
        p, b = (int(x) for x in start)
        if not grid.feasible[0, p, b]:
            raise InvalidParameterError(f"start node {start} of the first sample is not feasible")
        start = (p, b)
    return _solve(robot, grid, objective, dt, qd_max, start, frame, keep, 0.0)


# ---------------------------------------------------------------------- the DP


def _solve(
    robot: Robot,
    grid: PathGrid,
    objective: Objective | Callable[[FloatArray], Any],
    dt: float,
    qd_max: Any,
    start: tuple[int, int] | None,
    frame: str | None,
    keep: KeepOut | None,
    seconds_grid: float,
) -> PathPlan:
    began = time.perf_counter()
    K, P, B = grid.shape
    colliding, clear = 0, np.zeros(0)
    if keep is not None:
        grid, dense, colliding = screen(robot, grid, keep)
    limit = robot.qd_max if qd_max is None else as_gains(qd_max, "qd_max")
    limit = np.array(np.broadcast_to(limit, (robot.n,)), dtype=np.float64)
    if not (limit > 0).all():
        raise InvalidParameterError(f"qd_max must be positive (rad/s); got {limit}")
    index, q, per_sample = _nodes(grid, start)
    M = len(q)
    kernels = _kernels(M)
    graph = _graph(kernels, q, per_sample, np.ascontiguousarray(limit * dt))
    bottleneck = objective in _BOTTLENECK
    margin = np.minimum(q - robot.q_min, robot.q_max - q).min(axis=1) if M else np.zeros(0)
    if keep is not None:
        clear = np.ascontiguousarray(dense.reshape(-1)[index])
    value, edge = _node_values(robot, q, objective, margin, clear, graph[1], dt, frame)
    best, parent = np.empty(M), np.empty(M, np.int64)
    reached, ends, counts = np.empty(M, np.bool_), np.empty(M, np.bool_), np.zeros(2, np.int64)
    kernels.forward(*graph, np.ones(M, np.bool_), value, bottleneck, edge, best, parent, reached,
                    counts)  # fmt: skip
    kernels.backward(*graph, reached, ends)
    on = reached & ends  # the nodes on some complete admissible path
    components = kernels.components(*graph, on, np.empty(M, np.int64))
    reached_per = np.bincount(np.repeat(np.arange(K), per_sample)[reached], minlength=K)
    first_infeasible = _first(per_sample == 0)
    stats = PlanStats(
        nodes=K * P * B, feasible_nodes=M, feasible_per_sample=per_sample,
        reachable_nodes=int(reached_per.sum()), traversable_nodes=int(on.sum()),
        pairs_checked=int(counts[0]), transitions=int(counts[1]),
        components=int(components), first_infeasible=first_infeasible,
        first_unreachable=None if first_infeasible is not None else _first(reached_per == 0),
        seconds_grid=seconds_grid, seconds_dp=0.0, colliding_nodes=colliding,
    )  # fmt: skip
    name = objective if isinstance(objective, str) else getattr(objective, "__name__", "cost")
    last = np.arange(graph[1][K - 1], graph[1][K])
    last = last[reached[last]]
    if len(last) == 0 or first_infeasible is not None:
        stats = dataclasses.replace(stats, seconds_dp=time.perf_counter() - began)
        nan, none = np.full((K, robot.n), np.nan), np.full(K, -1, np.int64)
        return PathPlan(nan, grid.t, math.nan, name, False, grid.parameter, nan[:, 0].copy(),
                        none, math.nan, math.nan, dt, limit, stats, grid)  # fmt: skip
    if bottleneck:
        optimum = float(best[last].max())
        # among the max-min paths, the shortest: the additive DP over the nodes >= optimum
        kernels.forward(*graph, on & (value >= optimum), np.zeros(M), False, 1.0, best, parent,
                        reached, np.zeros(2, np.int64))  # fmt: skip
        last = last[reached[last]]
    rows = np.empty(K, np.int64)
    rows[K - 1] = last[np.argmin(best[last])]
    for k in range(K - 1, 0, -1):
        rows[k - 1] = parent[rows[k]]
    if not bottleneck:
        optimum = float(best[rows[K - 1]])
        optimum = -optimum if objective == "manipulability" else optimum
    stats = dataclasses.replace(stats, seconds_dp=time.perf_counter() - began)
    flat = index[rows]  # rows of the dense grid (k, p, b)
    path_q = q[rows].copy()
    return PathPlan(
        path_q, grid.t, optimum, name, True, grid.parameter,
        grid.values[np.arange(K), (flat // B) % P], (flat % B).astype(np.int64),
        float(margin[rows].min()), float(np.sum(np.linalg.norm(np.diff(path_q, axis=0), axis=1))),
        dt, limit, stats, grid, float(clear[rows].min()) if keep is not None else math.nan,
    )  # fmt: skip


def _nodes(
    grid: PathGrid, start: tuple[int, int] | None
) -> tuple[NDArray[np.int64], FloatArray, NDArray[np.int64]]:
    """The feasible nodes, sample by sample (only ``start`` on the first sample, if
    given): their rows in the dense grid ``(M,)``, configurations ``(M, n)``, and how
    many each sample has ``(K,)``."""
    K = grid.shape[0]
    feasible = grid.feasible
    if start is not None:
        feasible = feasible.copy()
        keep = feasible[0, start[0], start[1]]
        feasible[0] = False
        feasible[0, start[0], start[1]] = keep
    index = np.flatnonzero(feasible.reshape(-1))
    q = np.ascontiguousarray(grid.q.reshape(-1, grid.q.shape[-1])[index])
    return index, q, feasible.reshape(K, -1).sum(axis=1).astype(np.int64)


def _graph(kernels: Any, q: FloatArray, per_sample: NDArray[np.int64], delta: FloatArray
           ) -> tuple[Any, ...]:  # fmt: skip
    """The arguments every pass of :mod:`redres.plan._kernels` starts with: ``(q, start,
    order, keys, key, delta)``, the nodes sorted per sample."""
    offsets = np.concatenate(([0], np.cumsum(per_sample))).astype(np.int64)
    order, keys = np.empty(len(q), np.int64), np.empty(len(q))
    key = np.empty(len(per_sample), np.int64)
    kernels.sort_samples(q, offsets, delta, order, keys, key)
    return q, offsets, order, keys, key, delta


def _node_values(
    robot: Robot,
    q: FloatArray,
    objective: Objective | Callable[[FloatArray], Any],
    margin: FloatArray,
    clear: FloatArray,
    offsets: NDArray[np.int64],
    dt: float,
    frame: str | None,
) -> tuple[FloatArray, float]:
    """Each node's value for the DP and the weight of the step length."""
    M = len(q)
    if objective == "joint_limit_margin":
        return np.ascontiguousarray(margin), 0.0
    if objective == "obstacle_clearance":
        return clear, 0.0
    if objective == "path_length":
        return np.zeros(M), 1.0
    if objective == "manipulability":
        K = len(offsets) - 1
        h = np.full(K, dt)
        if K > 1:
            h[0] = h[-1] = dt / 2.0
        weight = np.repeat(h, np.diff(offsets))
        return np.ascontiguousarray(-weight * _manipulability(robot, q, frame)), 0.0
    assert callable(objective)
    cost = np.asarray(objective(q.copy()), dtype=np.float64)
    if cost.shape != (M,):
        raise ShapeError(
            f"the cost function must map configurations (M, n) to (M,); got shape "
            f"{cost.shape} for M = {M}"
        )
    if not np.isfinite(cost).all():
        raise NonFiniteError("the cost function returned NaN or infinity")
    return np.ascontiguousarray(cost), 0.0


def _manipulability(robot: Robot, q: FloatArray, frame: str | None) -> FloatArray:
    """Yoshikawa's ``√det(J Jᵀ)`` of each row of ``q`` (the frame's 6-row Jacobian)."""
    from .. import batch

    out = np.empty(len(q))
    for a in range(0, len(q), 65536):
        J = batch.jacobian(robot, q[a : a + 65536], frame=frame)
        JJ = J @ np.swapaxes(J, -1, -2)
        out[a : a + 65536] = np.sqrt(np.maximum(np.linalg.det(JJ), 0.0))
    return out


def _kernels(nodes: int) -> Any:
    """The kernel module: compiled, or its plain-Python twin for a grid of at most
    :data:`_PLAIN_NODES` feasible nodes while it compiles behind; a larger grid waits for
    the compilation (:func:`redres._compile.warm`: minutes of plain Python saved)."""
    module = KERNELS.compiled()
    if module is not None:
        return module
    if _compile.enabled() and nodes > _PLAIN_NODES:
        _compile.warm(("plan",))
    return KERNELS.required("the path planner")


def _first(mask: NDArray[np.bool_]) -> int | None:
    hit = np.flatnonzero(mask)
    return int(hit[0]) if len(hit) else None


def _check_objective(objective: Any, keep: KeepOut | None) -> None:
    if objective == "obstacle_clearance" and keep is None:
        raise InvalidParameterError(
            "objective 'obstacle_clearance' needs obstacles=[SphereObstacle(...), "
            "CapsuleObstacle(...)] (redres.objectives)"
        )
    if callable(objective) or objective in OBJECTIVES:
        return
    raise InvalidParameterError(
        f"objective must be one of {list(OBJECTIVES)} or a function cost(q (M, n)) -> (M,); "
        f"got {objective!r}"
    )


def _default_parameter(robot: Robot, frame: str | None) -> Parameter:
    from ..ik.srs import NotSRSError, SRSArm

    try:
        SRSArm.from_robot(robot, frame)
    except NotSRSError:
        return "q7"
    return "arm_angle"


def _arm_angle(robot: Robot, q: FloatArray) -> float:
    from ..tasks import ArmAngleTask

    return ArmAngleTask().value(robot, q)


def _start_node(grid: PathGrid, q0: FloatArray, anchor: float) -> tuple[int, int]:
    """The node of the first sample at ``q0``: the value ``anchor`` and the nearest
    branch; refused when it is not ``q0``."""
    p = int(np.argmin(np.abs(np.angle(np.exp(1j * (grid.values[0] - anchor))))))
    gap = np.abs(grid.q[0, p] - q0).max(axis=1)
    gap = np.where(np.isnan(gap), np.inf, gap)
    b = int(np.argmin(gap))
    if not gap[b] <= Q0_TOL:
        raise InvalidParameterError(
            f"q0 is not a configuration at the path's first pose: the nearest solution there "
            f"differs by {gap[b]:.3g} rad (tolerance {Q0_TOL:g}); give a q0 with fk(q0) equal "
            "to the first pose, or q0=None to leave the start free"
        )
    return p, b
