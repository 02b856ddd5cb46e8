"""The dynamic programming over a path's grid: the optimal admissible path, and the
topology of the feasible region.

A joint path is one node of the grid (:mod:`redres.plan.grid`) per sample; it is
admissible when every node is feasible (within the joint limits, clear of the
obstacles) and every step respects the velocity limits, ``|q_{k+1} − q_k| ≤ q̇_max·dt``
joint by joint (a transition between branches is allowed exactly when it passes this
test: the check, not a rule about branches, decides). Over the admissible paths,
Bellman's principle (Ferrentino, Salvioli & Chiacchio, Robotics 10(1):42, 2021, eq. 9)
gives the optimum of an additive cost by the recursion

    V_0(x) = c_0(x),   V_{k+1}(y) = min over admissible x → y of [V_k(x) + e(x, y)] + c_{k+1}(y)

and the path by following the minimising ``x`` back from the best last node
(:mod:`redres.plan.objectives` gives ``c`` and ``e``). A max-min objective (the margin,
the clearance) is a *bottleneck* problem: the same recursion with ``(min, max)`` for
``(+, min)``, ``V_{k+1}(y) = min(m(y), max_x V_k(x))``, exact because ``min`` is
monotone (Pollack, "The maximum capacity through a network", Operations Research 8(5),
1960). Many paths share that optimum; among them the plan is the shortest (a second pass
of the additive recursion over the nodes with ``m ≥ V*``). The additive objectives are
summed in path order, ``(V_k + e) + c``, so that a sum over one path computed in that
order equals the DP's value to the last bit.

Acceleration limits. With ``qdd_max``, three consecutive nodes must also satisfy
``|q_{k+1} − 2 q_k + q_{k−1}| ≤ q̈_max·dt²`` joint by joint (the central second
difference; the velocity at the first and last samples is free). A node alone no longer
decides what may follow it, so the state of the recursion becomes the *transition*
``(x_{k−1}, x_k)``, an edge of the velocity graph (the state augmented by the previous
node, which makes a second-order constraint first-order again):

    W_1(x_0, x_1) = (c_0(x_0) + e(x_0, x_1)) + c_1(x_1),
    W_{k+1}(x_k, x_{k+1}) = min over x_{k−1} with an admissible triple of
                            [W_k(x_{k−1}, x_k) + e(x_k, x_{k+1})] + c_{k+1}(x_{k+1}),

the same recursion over the edges (the bottleneck version alike), whose count is the
number of velocity transitions; each edge tries the edges leaving its second node, so
the work is ``Σ_x in(x)·out(x)`` acceleration tests. Reachability, the nodes on a
complete path, the first unreachable sample and the second pass of a max-min objective
come from the edges; the components are counted over the velocity transitions between
the nodes on a complete path (two pieces joined only by transitions the acceleration
limits forbid count as one).

Topology. The first sample with no feasible node, else the first that no admissible
path from the start reaches, tells where a path is impossible. Of the nodes that lie on
some complete admissible path (reached from the start *and* leading to the end), the
connected components under the transitions are the pieces of the feasible region a
robot cannot move between along this path (:attr:`PlanStats.components`): a local
scheme stays in the piece it starts in.

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
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .. import _compile
from .._validate import FloatArray
from ..errors import InvalidParameterError, NonFiniteError, ShapeError
from .clearance import KeepOut, screen
from .grid import PathGrid
from .objectives import BOTTLENECK, Objective, node_values
from .path_plan import PathPlan, PlanStats

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["KERNELS", "solve"]

#: The DP kernels (:mod:`redres.plan._kernels`). Cold (2026-12-07, 2 shared cores, load
#: 3.0): a first 2-sample plan 4.3, 4.6, 8.5 s on an empty cache; warm 0.7, 0.7, 1.2 s.
KERNELS = _compile.KernelGroup("plan", ("redres.plan._kernels",), cold_seconds=5.0)
#: A grid with at most this many feasible nodes runs through the kernels' plain-Python
#: twin while they compile behind; a larger one waits for the compilation.
_PLAIN_NODES = 20_000


def solve(
    robot: Robot,
    grid: PathGrid,
    objective: Objective | Callable[[FloatArray], Any],
    dt: float,
    qd_max: Any,
    start: tuple[int, int] | None,
    frame: str | None,
    keep: KeepOut | None,
    seconds_grid: float,
    qdd_max: Any = None,
) -> PathPlan:
    """The optimal admissible path over ``grid`` (module docstring): the body of
    :func:`redres.plan.plan_path` and :func:`redres.plan.solve_grid`, which check the
    rest of their arguments."""
    began = time.perf_counter()
    K, P, B = grid.shape
    colliding, clear = 0, np.zeros(0)
    if keep is not None:
        grid, dense, colliding = screen(robot, grid, keep)
    limit = _limit(robot.qd_max if qd_max is None else qd_max, "qd_max", robot.n, "rad/s")
    index, q, per_sample = _nodes(grid, start)
    M = len(q)
    kernels = _kernels(M)
    graph = _graph(kernels, q, per_sample, np.ascontiguousarray(limit * dt))
    bottleneck = objective in BOTTLENECK
    margin = np.minimum(q - robot.q_min, robot.q_max - q).min(axis=1) if M else np.zeros(0)
    if keep is not None:
        clear = np.ascontiguousarray(dense.reshape(-1)[index])
    value, edge = node_values(robot, q, objective, margin, clear, graph[1], dt, frame)
    accel = None
    if qdd_max is not None:
        accel = _limit(qdd_max, "qdd_max", robot.n, "rad/s²")
    if accel is not None and K >= 2:
        found = _edge_dp(kernels, graph, np.ascontiguousarray(accel * dt * dt), value,
                         bottleneck, edge)  # fmt: skip
    else:
        found = _node_dp(kernels, graph, value, bottleneck, edge)
    components = kernels.components(*graph, found.on, np.empty(M, np.int64))
    reached_per = np.bincount(np.repeat(np.arange(K), per_sample)[found.reached], minlength=K)
    first_infeasible = _first(per_sample == 0)
    stats = PlanStats(
        nodes=K * P * B, feasible_nodes=M, feasible_per_sample=per_sample,
        reachable_nodes=int(reached_per.sum()), traversable_nodes=int(found.on.sum()),
        pairs_checked=found.counts[0], transitions=found.counts[1],
        components=int(components), first_infeasible=first_infeasible,
        first_unreachable=None if first_infeasible is not None else _first(reached_per == 0),
        seconds_grid=seconds_grid, seconds_dp=0.0, colliding_nodes=colliding,
        edge_pairs_checked=found.counts[2], edge_pairs=found.counts[3],
    )  # fmt: skip
    name = objective if isinstance(objective, str) else getattr(objective, "__name__", "cost")
    rows = found.rows
    if rows is None or first_infeasible is not None:
        stats = dataclasses.replace(stats, seconds_dp=time.perf_counter() - began)
        nan, none = np.full((K, robot.n), np.nan), np.full(K, -1, np.int64)
        return PathPlan(nan, grid.t, math.nan, name, False, grid.parameter, nan[:, 0].copy(),
                        none, math.nan, math.nan, dt, limit, stats, grid,
                        qdd_max=accel)  # fmt: skip
    optimum = -found.optimum if objective == "manipulability" else found.optimum
    stats = dataclasses.replace(stats, seconds_dp=time.perf_counter() - began)
    flat = index[rows]  # rows of the dense grid (k, p, b)
    path_q = q[rows].copy()
    return PathPlan(
        path_q, grid.t, optimum, name, True, grid.parameter,
        grid.values[np.arange(K), (flat // B) % P], (flat % B).astype(np.int64),
        float(margin[rows].min()), float(np.sum(np.linalg.norm(np.diff(path_q, axis=0), axis=1))),
        dt, limit, stats, grid, float(clear[rows].min()) if keep is not None else math.nan,
        qdd_max=accel,
    )  # fmt: skip


@dataclass(frozen=True)
class _Found:
    """What a DP found: ``reached`` ``(M,)`` the nodes an admissible path from the start
    reaches, ``on`` ``(M,)`` those on a complete one, ``counts`` (node pairs tested,
    transitions, transition pairs tested, allowed), and the optimal path's node ``rows``
    ``(K,)`` with its ``optimum`` (None, NaN: no path)."""

    reached: NDArray[np.bool_]
    on: NDArray[np.bool_]
    counts: tuple[int, int, int, int]
    rows: NDArray[np.int64] | None = None
    optimum: float = math.nan


def _node_dp(kernels: Any, graph: tuple[Any, ...], value: FloatArray, bottleneck: bool,
             edge: float) -> _Found:  # fmt: skip
    """The recursion over nodes (velocity limits only)."""
    q, offsets = graph[0], graph[1]
    M, K = len(q), len(offsets) - 1
    best, parent = np.empty(M), np.empty(M, np.int64)
    reached, ends, counts = np.empty(M, np.bool_), np.empty(M, np.bool_), np.zeros(2, np.int64)
    kernels.forward(*graph, np.ones(M, np.bool_), value, bottleneck, edge, best, parent, reached,
                    counts)  # fmt: skip
    kernels.backward(*graph, reached, ends)
    on = reached & ends  # the nodes on some complete admissible path
    tally = (int(counts[0]), int(counts[1]), 0, 0)
    last = np.arange(offsets[K - 1], offsets[K])
    last = last[reached[last]]
    if len(last) == 0:
        return _Found(reached.copy(), on, tally)
    first_reached = reached.copy()
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
    return _Found(first_reached, on, tally, rows, optimum)


def _edge_dp(kernels: Any, graph: tuple[Any, ...], accel: FloatArray, value: FloatArray,
             bottleneck: bool, edge: float) -> _Found:  # fmt: skip
    """The recursion over edges (velocity and acceleration limits): the state at sample
    ``k + 1`` is the transition ``x_k → x_{k+1}``, so that the next step can be checked
    against ``|q_{k+2} − 2 q_{k+1} + q_k| ≤ accel`` (module docstring)."""
    q, offsets = graph[0], graph[1]
    M, K = len(q), len(offsets) - 1
    ones = np.ones(M, np.bool_)
    first, source, target, tested = kernels.edge_list(*graph, ones)
    E = len(target)
    best, parent = np.empty(E), np.empty(E, np.int64)
    reached, ends, counts = np.empty(E, np.bool_), np.empty(E, np.bool_), np.zeros(2, np.int64)
    opening, closing = int(offsets[1]), int(offsets[K - 1])
    kernels.edge_forward(q, first, source, target, accel, ones, opening, value, bottleneck, edge,
                         best, parent, reached, counts)  # fmt: skip
    kernels.edge_backward(q, first, source, target, accel, ones, closing, ends)
    node_reached = np.zeros(M, np.bool_)
    node_reached[:opening] = True
    node_reached[target[reached]] = True
    through = reached & ends
    on = np.zeros(M, np.bool_)
    on[source[through]] = True
    on[target[through]] = True
    tally = (int(tested), E, int(counts[0]), int(counts[1]))
    last = np.flatnonzero(reached & (target >= closing))  # the edges into the last sample
    if len(last) == 0:
        return _Found(node_reached, on, tally)
    if bottleneck:
        optimum = float(best[last].max())
        # among the max-min paths, the shortest: the additive DP over the nodes >= optimum
        kernels.edge_forward(q, first, source, target, accel, on & (value >= optimum), opening,
                             np.zeros(M), False, 1.0, best, parent, reached,
                             np.zeros(2, np.int64))  # fmt: skip
        last = last[reached[last]]
    e = int(last[np.argmin(best[last])])
    if not bottleneck:
        optimum = float(best[e])
    rows = np.empty(K, np.int64)
    rows[K - 1] = target[e]
    for k in range(K - 2, -1, -1):
        rows[k] = source[e]
        e = int(parent[e])
    return _Found(node_reached, on, tally, rows, optimum)


def _limit(value: Any, name: str, n: int, unit: str) -> FloatArray:
    """A positive limit per joint ``(n,)`` from a scalar or ``(n,)`` (``inf``: none)."""
    try:
        raw = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"{name} must be a number or {n} numbers ({unit}); got {value!r}"
        ) from None
    if raw.shape not in ((), (n,)):
        raise ShapeError(f"{name} must be a scalar or shape ({n},); got shape {raw.shape}")
    if np.isnan(raw).any():
        raise NonFiniteError(f"{name} contains NaN")
    limit = np.array(np.broadcast_to(raw, (n,)))
    if not (limit > 0).all():
        raise InvalidParameterError(f"{name} must be positive ({unit}); got {limit}")
    return limit


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
