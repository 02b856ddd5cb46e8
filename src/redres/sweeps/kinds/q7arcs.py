"""The arm angles of a pose by the closed form at ``q7``: a redundancy map of the arms that
:func:`redres.ik.analytic.analytic_arm` accepts but that are not S-R-S (the Panda, FR3).

At a fixed ``q7`` the closed form gives every configuration of the pose, one per branch
``b`` (:mod:`redres.ik.analytic`: code ``4 i4 + 2 iφ + is``). Along ``q7`` each branch is
a smooth curve of configurations, and the self-motion manifold of the pose (Burdick 1989)
is these curves glued at their *folds*: where two branches meet (their roots merge: the
``φ`` of step 3 or the elbow of step 2), the manifold turns back in ``q7`` and goes on
along the other branch. The arm angle (:class:`redres.tasks.ArmAngleTask`) is a smooth
function along it. So, per pose, on arrays over all poses of a batch:

1. **Grid.** :func:`~redres.ik.analytic.at_q7_batch` (``residuals=False``: no FK
   errors) at ``grid`` values of ``q7`` over its limits: which branch exists, and where
   it is within the joint limits.
2. **Folds.** Between grid values where branches appear or vanish, each is paired with
   the branch whose root merges with its own there (code ``b ^ 2``: the roots of step 3;
   ``b ^ 4``: the elbow; the nearer where both vanish), and the fold is
   found by the secant method on the squared distance ``d²`` between them (linear in
   ``q7`` near the fold: ``d ∝ √|q7 − q7*|``), bracketed by where they exist; it is
   sampled on both branches at the first ``q7`` found where they are closer than
   :data:`FOLD_GAP` (joint space). The piece of the curve between the two samples is
   short enough that step 6 adds each side's arm angle to the other (at 1e-2 rad apart
   the arm angle there was off by up to 1.4e-3 rad: it turns back sharply at folds).
   Then the folds hidden between two values of ``q7`` evaluated (a pair of branches
   that lives between two of them, or vanishes between two where it exists): from the
   argument ``y`` of the root of step 3 at each value, where ``1 − |y|`` has an extreme
   toward 0 between three values of the same sign (:mod:`.q7folds`).
3. **Swings.** Each step between neighbouring samples of a branch where a joint moves
   more than :data:`.q7samples._JUMP` is halved, and its halves again, until none does (or the
   step is :data:`.q7samples._NARROW`): near the shoulder's singularity joints 1 and 3 swing
   through π in a stretch of ``q7`` that can be far shorter than the grid's step, and
   the swing can pass outside their limits (through ±π) between two samples within them.
4. **Joint turns.** Where a joint's margin inside its nearer limit turns back between
   samples of a branch (the slope between samples changes sign, or the parabola through
   three samples has its vertex inside the first or last step, beyond them) within
   :data:`.q7samples._TURN_RANGE` of the limit, and the parabola puts the turn across the limit or
   within :data:`.q7samples._TURN_NEAR` of it, the vertex is sampled; then the parabola through the
   vertex and its two nearest points (successive parabolic interpolation), to
   :data:`.q7samples.TURN_TOL` in ``q7``. So a joint that leaves its limits and comes back between
   two samples within them, or enters them and leaves between two samples outside, is
   sampled there.
5. **Limit ends.** Between neighbouring samples of a branch, one within the limits and
   one outside, the ``q7`` where a joint meets its limit: the Illinois false-position
   method on the margin (the smallest distance of a joint inside its limits, negative
   outside), to :data:`END_TOL` in ``q7`` or in the margin.
6. **Arcs.** Each run of samples within the limits on a branch is one piece of the
   manifold; its arm angles (unwrapped along it) span ``[min, max]``. Where the arm
   angle turns back (as in step 4, the Panda's turns back along ``q7``) its turn is
   found by successive parabolic interpolation too, and added. At a fold within the
   limits the partner branch's arm angle is added to each side, so the two runs overlap
   and the union joins them.

What a map stores is then the stored form of the sweep's closed form: per branch slot,
its runs' arcs as pieces; the union over the branches. Not certified: steps 3, 4 and 6
find a turn or a swing from the samples around it (a joint that turns twice within one
step unseen is missed), and step 2 finds a hidden pair of folds from the values of
``1 − |y|`` around it (one that rises above 0, or dips below, between values where it
does not turn toward 0 is missed; grid step ``5.8/(grid − 1)`` rad for the Panda;
docs/sweeps.md gives the measured cases).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ...tasks.arm_angle import ArmAngleTask
from .q7folds import FOLD_GAP, Evaluated, folds, hidden
from .q7samples import (
    END_TOL,
    TURN_ROUNDS,
    TURN_TOL,
    BranchSolver,
    Samples,
    branch_at,
    joint_turns,
    limit_ends,
    narrowed,
    parabola_vertex,
    refine,
    turns,
    wrap,
)

if TYPE_CHECKING:
    from ...robot import Robot

__all__ = ["END_TOL", "FOLD_GAP", "GRID", "Q7Arcs", "merged", "q7_arcs"]

GRID = 41  #: q7 values of the grid over the joint's range
_CHUNK = 256  # poses per pass
_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class Q7Arcs:
    """The runs of a batch of poses (module docstring), flat over every pose.

    Attributes:
        pose, branch: each run's pose index and branch code, ``(R,)``.
        lo, hi: its arm angles, rad, ``(R,)``: ``lo`` in ``[-π, π)``, ``lo ≤ hi``
            (``hi − lo ≥ 2π``: the whole circle).
        q7: the ``q7`` at its two ends, rad, ``(R, 2)``.
        links: pairs of runs joined at a fold within the limits, ``(L, 2)``.
        poses: how many poses.
    """

    pose: np.ndarray
    branch: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    q7: np.ndarray
    links: np.ndarray
    poses: int

    def stored(self, slots: int) -> dict[str, np.ndarray]:
        """The fields of a redundancy map (:mod:`redres.sweeps.kinds.redundancy`), with
        slot ``b`` the branch of code ``b``: ``intervals`` ``(N, 8, slots, 2)``, ``count``,
        ``width``, ``union`` ``(N, slots, 2)``, ``union_count``, ``total_width``."""
        lo, hi, owner = _pieces(self.lo, self.hi, self.pose * 8 + self.branch)
        out: dict[str, np.ndarray] = {}
        per_branch = merged(lo, hi, owner, self.poses * 8, slots)
        for key, value in zip(("intervals", "count", "width"), per_branch):
            out[key] = value.reshape(self.poses, 8, *value.shape[1:])
        union = merged(lo, hi, owner // 8, self.poses, slots)
        out["union"], out["union_count"], out["total_width"] = union
        return out

    def components(self) -> list[list[list[tuple[float, float]]]]:
        """Per pose, the arm-angle pieces (``[-π, π]``, merged) of each connected piece of
        the manifold within the limits (runs joined at folds): what a trace from one of
        its configurations visits."""
        parent = np.arange(len(self.pose))

        def root(i: int) -> int:
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = int(parent[i])
            return i

        for a, b in self.links:
            parent[root(int(a))] = root(int(b))
        roots = np.array([root(i) for i in range(len(self.pose))], dtype=np.int64)
        out: list[list[list[tuple[float, float]]]] = [[] for _ in range(self.poses)]
        for r in np.unique(roots):
            lo, hi, owner = _pieces(self.lo[roots == r], self.hi[roots == r],
                                    np.zeros(int((roots == r).sum()), dtype=np.int64))  # fmt: skip
            parts, count, _ = merged(lo, hi, owner, 1, 2 * len(lo) + 2)
            out[int(self.pose[r])].append([(float(a), float(b)) for a, b in parts[0, : count[0]]])
        return out


def q7_arcs(
    robot: Robot,
    T: np.ndarray,
    *,
    frame: str | None = None,
    points: tuple[str, str, str] = ("shoulder", "elbow", "wrist"),
    reference: np.ndarray | None = None,
    grid: int = GRID,
) -> Q7Arcs:
    """The runs of the poses ``T`` ``(N, 4, 4)`` (module docstring).

    Raises:
        NotAnalyticError: the arm has no closed form at ``q7``.
    """
    task = ArmAngleTask(*points, reference=(0.0, 0.0, 1.0) if reference is None else reference)
    solver = BranchSolver(robot, frame, task)
    poses = np.ascontiguousarray(T, dtype=np.float64).reshape(-1, 4, 4)
    starts = range(0, len(poses), _CHUNK)
    parts = [_chunk(solver, poses[s : s + _CHUNK], grid) for s in starts]
    if not parts:
        empty = np.zeros(0, dtype=np.int64)
        return Q7Arcs(empty, empty, np.zeros(0), np.zeros(0), np.zeros((0, 2)),
                      np.zeros((0, 2), dtype=np.int64), 0)  # fmt: skip
    offsets = np.cumsum([0] + [len(p.pose) for p in parts])
    return Q7Arcs(
        pose=np.concatenate([p.pose + s for p, s in zip(parts, starts)]),
        branch=np.concatenate([p.branch for p in parts]),
        lo=np.concatenate([p.lo for p in parts]),
        hi=np.concatenate([p.hi for p in parts]),
        q7=np.concatenate([p.q7 for p in parts]),
        links=np.concatenate([p.links + o for p, o in zip(parts, offsets)]),
        poses=len(poses),
    )


def _pieces(lo: np.ndarray, hi: np.ndarray, owner: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Arcs (``lo`` in ``[-π, π)``) as pieces inside ``[-π, π]`` (:func:`redres.ik.arcs.pieces`
    on arrays): an arc through ``±π`` as two, the whole circle as ``(-π, π)``."""
    full = hi - lo >= _TWO_PI - 1e-12
    over = ~full & (hi > math.pi)
    first_hi = np.where(full | over, math.pi, hi)
    first_lo = np.where(full, -math.pi, lo)
    return (np.concatenate((first_lo, np.full(int(over.sum()), -math.pi))),
            np.concatenate((first_hi, hi[over] - _TWO_PI)),
            np.concatenate((owner, owner[over])))  # fmt: skip


def merged(lo: np.ndarray, hi: np.ndarray, owner: np.ndarray, owners: int, slots: int
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """Pieces inside ``[-π, π]`` of ``owners`` sets, merged where they overlap or touch and
    packed as :func:`redres.ik.arcs.pack` does, on arrays.

    Args:
        lo, hi: the pieces, rad, ``(P,)``; owner: the set of each, ``(P,)`` in
            ``[0, owners)``.
        owners, slots: how many sets; pieces kept per set.

    Returns:
        ``(pieces (owners, slots, 2) NaN-padded, count (owners,), width (owners,))``.
    """
    order = np.lexsort((lo, owner))
    lo, hi, owner = lo[order], hi[order], owner[order]
    shift = 8.0 * owner  # the sets apart (pieces lie in [-π, π]), to find where they join
    reach = np.maximum.accumulate(hi + shift) - shift if len(hi) else hi
    start = np.ones(len(lo), dtype=bool)
    start[1:] = (owner[1:] != owner[:-1]) | (lo[1:] > reach[:-1])
    begin = np.flatnonzero(start)
    top = np.maximum.reduceat(hi, begin) if len(begin) else hi  # exact, unlike `reach`
    keep = top > lo[begin]
    begin, top = begin[keep], top[keep]
    who = owner[begin]
    rank = np.arange(len(begin)) - np.searchsorted(who, who)
    out = np.full((owners, slots, 2), np.nan)
    fits = rank < slots
    out[who[fits], rank[fits], 0] = lo[begin[fits]]
    out[who[fits], rank[fits], 1] = top[fits]
    count = np.bincount(who, minlength=owners).astype(np.int64)
    width = np.bincount(who, weights=top - lo[begin], minlength=owners)
    return out, count, width


def _chunk(solver: BranchSolver, T: np.ndarray, grid: int) -> Q7Arcs:
    """:func:`q7_arcs` of at most ``_CHUNK`` poses."""
    s, folds = sample_along_q7(solver, T, grid)
    return _runs(solver, T, s, folds)


def sample_along_q7(solver: BranchSolver, T: np.ndarray, grid: int) -> tuple[Samples, int]:
    """Every branch of the poses ``T`` ``(N, 4, 4)`` sampled along ``q7`` (steps 1-5 of
    the module docstring): the samples, sorted, and how many folds (the samples of the
    two sides of fold ``f`` are tagged ``2f`` and ``2f + 1``)."""
    count = len(T)
    g = np.linspace(solver.range[0], solver.range[1], grid)
    q, inside, roots = solver.evaluate(np.repeat(T, grid, axis=0), np.tile(g, count))
    seen = Evaluated()
    seen.add(np.repeat(np.arange(count), grid), np.tile(g, count), roots)
    q = q.reshape(count, grid, 8, 7).transpose(0, 2, 1, 3)  # (N, 8, G, 7)
    inside = inside.reshape(count, grid, 8).transpose(0, 2, 1)
    rows = np.repeat(np.arange(8 * count), grid)
    s = Samples(rows, np.tile(g, 8 * count), inside.ravel(), q.reshape(-1, 7),
                np.full(len(rows), -1))  # fmt: skip
    x = roots[:, 0].reshape(count, grid)
    found = hidden(solver, T, s, seen, folds(solver, T, g, (q, inside, x), s, seen))
    s.sort()
    refine(solver, T, s)
    joint_turns(solver, T, s)
    limit_ends(solver, T, s)
    s.sort()
    return s, found


def _runs(solver: BranchSolver, T: np.ndarray, s: Samples, folds: int) -> Q7Arcs:
    """The runs of samples within the limits and their arm-angle arcs (module docstring,
    step 6)."""
    take = np.flatnonzero(s.inside)
    row, x, tag = s.row[take], s.x[take], s.tag[take]
    before = take - 1
    first = np.ones(len(take), dtype=bool)
    first[1:] = (before[1:] != take[:-1]) | (row[1:] != row[:-1])  # a gap or a new row
    run = np.cumsum(first) - 1
    phi = solver.angle(s.q[take])
    start = np.flatnonzero(first)
    turn = np.zeros(len(phi))
    turn[1:] = wrap(np.diff(phi))
    turn[first] = 0.0
    total = np.cumsum(turn)
    head = start[run]
    u = phi[head] + total - total[head]  # unwrapped along each run
    extra_run, extra_u = _extrema(solver, T, row, x, u, run)
    links = np.zeros((0, 2), dtype=np.int64)
    if folds:
        side = np.full(2 * folds, -1)  # the in-sample of each side of each fold
        tagged = np.flatnonzero(tag >= 0)
        side[tag[tagged]] = tagged
        pairs = side.reshape(-1, 2)
        pairs = pairs[(pairs >= 0).all(axis=1)]
        links = run[pairs]
        bridge = u[pairs] + wrap(u[pairs[:, ::-1]] - u[pairs])  # the other side's angle
        extra_run = np.concatenate((extra_run, links.ravel()))
        extra_u = np.concatenate((extra_u, bridge.ravel()))
    runs = len(start)
    every_run, every_u = np.concatenate((run, extra_run)), np.concatenate((u, extra_u))
    lo, hi = np.full(runs, np.inf), np.full(runs, -np.inf)
    np.minimum.at(lo, every_run, every_u)
    np.maximum.at(hi, every_run, every_u)
    shift = _TWO_PI * np.floor((lo + math.pi) / _TWO_PI)
    last = np.append(start[1:], len(row)) - 1
    return Q7Arcs(row[start] // 8, row[start] % 8, lo - shift, hi - shift,
                  np.stack((x[start], x[last]), axis=1), links, len(T))  # fmt: skip


def _extrema(solver: BranchSolver, T: np.ndarray, row: np.ndarray, x: np.ndarray, u: np.ndarray,
             run: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """At each sample where the arm angle ``u`` turns back along its run, the arm angle at
    its turn: the vertex of the parabola through it and its neighbours, then through the
    vertex and its two nearest of them, :data:`TURN_ROUNDS` at most (successive
    parabolic interpolation, to :data:`.q7samples.TURN_TOL` in ``q7``); ``(run, angle)`` of each
    vertex within the limits."""
    mid = np.flatnonzero((run[1:-1] == run[:-2]) & (run[1:-1] == run[2:])) + 1
    mid = mid[turns((x[mid - 1], x[mid], x[mid + 1]), (u[mid - 1], u[mid], u[mid + 1]))]
    if not len(mid):
        return np.zeros(0, np.int64), np.zeros(0)
    px = np.stack((x[mid - 1], x[mid], x[mid + 1]), axis=1)
    pu = np.stack((u[mid - 1], u[mid], u[mid + 1]), axis=1)
    top = parabola_vertex(tuple(px.T), tuple(pu.T))[1] > pu[:, 1]  # a maximum
    pose, branch = row[mid] // 8, row[mid] % 8
    out_run, out_u = [], []
    active = np.arange(len(mid))
    for _ in range(TURN_ROUNDS):
        vertex, _ = parabola_vertex(tuple(px[active].T), tuple(pu[active].T))
        lo, hi = px[active, 0], px[active, 2]
        vertex = np.clip(np.where(np.isfinite(vertex), vertex, px[active, 1]), lo, hi)
        q = branch_at(solver, T[pose[active]], vertex, branch[active])
        ok = solver.margin(q) >= 0.0
        active, vertex, q = active[ok], vertex[ok], q[ok]
        phi = solver.angle(q)
        value = pu[active, 1] + wrap(phi - pu[active, 1])
        out_run.append(run[mid][active])
        out_u.append(value)
        moved = np.abs(vertex - px[active, 1]) > TURN_TOL
        px[active], pu[active] = narrowed(px[active], pu[active], vertex, value, top[active])
        active = active[moved]
        if not len(active):
            break
    return np.concatenate(out_run), np.concatenate(out_u)
