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
3. **Swings.** Each step between neighbouring samples of a branch where a joint moves
   more than :data:`_JUMP` is halved, and its halves again, until none does (or the
   step is :data:`_NARROW`): near the shoulder's singularity joints 1 and 3 swing
   through π in a stretch of ``q7`` that can be far shorter than the grid's step, and
   the swing can pass outside their limits (through ±π) between two samples within them.
4. **Joint turns.** Where a joint's margin inside its nearer limit turns back between
   samples of a branch (the slope between samples changes sign, or the parabola through
   three samples has its vertex inside the first or last step, beyond them) within
   :data:`_TURN_RANGE` of the limit, and the parabola puts the turn across the limit or
   within :data:`_TURN_NEAR` of it, the vertex is sampled; then the parabola through the
   vertex and its two nearest points (successive parabolic interpolation), to
   :data:`_TURN_TOL` in ``q7``. So a joint that leaves its limits and comes back between
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
step unseen is missed), and step 2 sees the folds of a branch only where its existence
changes between grid values: a branch pair that lives between two grid values, or a
second fold in one grid interval, is missed (grid step ``5.8/(grid − 1)`` rad for the
Panda; docs/sweeps.md gives the measured cases).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ... import _compile, batch
from ...ik.analytic import analytic_arm, at_q7_batch
from ...tasks.arm_angle import ArmAngleTask, arm_angles

if TYPE_CHECKING:
    from ...robot import Robot

__all__ = ["END_TOL", "FOLD_GAP", "GRID", "Q7Arcs", "merged", "q7_arcs"]

GRID = 41  #: q7 values of the grid over the joint's range
END_TOL = 1e-8  #: rad: a limit end's bracket in q7, or its margin
FOLD_GAP = 1e-4  #: rad: the two sides of a fold, apart in joint space (2-norm)
_FOLD_TOL = 1e-12  # rad: a bracket in q7 narrower than this: not a fold of the pair
_EXTRA = 3  # samples between a fold and its grid value
_JUMP = 0.5  # rad: a joint's move between samples above which the step is halved
_LEVELS = 48  # halvings at most (a swing narrower than 2**-48 of the grid step is one)
_NARROW = 1e-13  # rad: a step of q7 not halved further
_TURN_RANGE = 0.5  # rad: a joint's turns farther inside (or outside) its limits are left
_TURN_NEAR = 0.05  # rad: a turn estimated this near its limit is sampled
_TURN_TOL = 1e-7  # rad: a turn with a sample this near its vertex is done
_TURN_ROUNDS = 6  # rounds of successive parabolic interpolation at most
_CHUNK = 256  # poses per pass
_SMALL = 4096  # evaluations below which one thread is faster than a parallel launch
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
    solver = _Solver(robot, frame, task)
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


class _Solver:
    """One branch's configuration at given poses and ``q7`` values, its margin inside the
    limits and its arm angle."""

    def __init__(self, robot: Robot, frame: str | None, task: ArmAngleTask) -> None:
        self.robot, self.frame, self.task = robot, frame, task
        arm = analytic_arm(robot, frame)
        self.q_min, self.q_max = arm.bounds
        self.centre = (self.q_min + self.q_max) / 2.0
        lo, hi = float(arm.bounds[0, 6]), float(arm.bounds[1, 6])
        finite = math.isfinite(lo) and math.isfinite(hi)
        self.range: tuple[float, float] = (lo, hi) if finite else (-math.pi, math.pi)

    def all_branches(self, T: np.ndarray, q7: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every branch: configurations ``(M, 8, 7)`` (NaN: no such branch), and whether
        each is within the limits ``(M, 8)``."""
        if len(q7) < _SMALL:  # a parallel launch waits for its slowest thread
            previous = _compile.threads(1)
            try:
                found = at_q7_batch(self.robot, T, q7, frame=self.frame, residuals=False)
            finally:
                _compile.threads(previous)
        else:
            found = at_q7_batch(self.robot, T, q7, frame=self.frame, residuals=False)
        q = np.full((len(q7), 8, 7), np.nan)
        inside = np.zeros((len(q7), 8), dtype=bool)
        rows, slots = np.nonzero(found.branch >= 0)
        b = found.branch[rows, slots]
        q[rows, b] = found.q[rows, slots]
        inside[rows, b] = found.within_limits[rows, slots]
        return q, inside

    def margin(self, q: np.ndarray) -> np.ndarray:
        """The smallest distance of a joint inside its limits, rad (negative outside,
        measured on the circle from the middle of the limits; NaN where ``q`` is NaN)."""
        q = self.centre + _wrap(q - self.centre)  # a joint past π is reported wrapped
        return np.minimum(q - self.q_min, self.q_max - q).min(axis=-1)

    def margins(self, q: np.ndarray) -> np.ndarray:
        """Each joint's distance inside its nearer limit, rad, ``(..., 7)`` (negative
        outside; :meth:`margin` is their smallest)."""
        q = self.centre + _wrap(q - self.centre)
        return np.minimum(q - self.q_min, self.q_max - q)

    def angle(self, q: np.ndarray) -> np.ndarray:
        """Arm angles of configurations ``(M, 7)``, rad."""
        if not len(q):
            return np.zeros(0)
        threads = 1 if len(q) < _SMALL else None  # a parallel launch waits for its slowest
        s, e, w = (batch.fk(self.robot, q, f, threads=threads)[:, :3, 3]
                   for f in (self.task.shoulder, self.task.elbow, self.task.wrist))  # fmt: skip
        return arm_angles(s, e, w, self.task.reference)


def _wrap(x: np.ndarray) -> np.ndarray:
    """Angles into ``[-π, π]`` (a third of the time of ``np.mod``)."""
    return np.asarray(x - _TWO_PI * np.round(x / _TWO_PI))


def _distance2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(_wrap(a - b) ** 2, axis=-1)


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


class _Samples:
    """Samples along ``q7`` of one chunk's rows (row ``8 n + b``: pose ``n``, branch
    ``b``), flat: sorted by row, then ``q7`` (:meth:`sort`; samples added are read after
    the next sort)."""

    _KEYS = ("row", "x", "inside", "q", "tag")

    def __init__(self, row: np.ndarray, x: np.ndarray, inside: np.ndarray, q: np.ndarray,
                 tag: np.ndarray) -> None:  # fmt: skip
        self.row = row  # (S,) int64
        self.x = x  # (S,) q7, rad
        self.inside = inside  # (S,) within the limits (False where there is no such branch)
        self.q = q  # (S, 7) rad; NaN where there is no such branch
        self.tag = tag  # (S,) the fold a sample is the side of, else -1
        self._new: list[tuple[np.ndarray, ...]] = []

    def add(self, row: np.ndarray, x: np.ndarray, q: np.ndarray, inside: np.ndarray,
            tag: np.ndarray | None = None) -> None:  # fmt: skip
        self._new.append((row, x, inside, q, np.full(len(row), -1) if tag is None else tag))

    def sort(self) -> None:
        for k, key in enumerate(self._KEYS):
            parts = [getattr(self, key)] + [new[k] for new in self._new]
            setattr(self, key, np.concatenate(parts))
        self._new = []
        order = np.lexsort((self.x, self.row))
        for key in self._KEYS:
            setattr(self, key, getattr(self, key)[order])

    def neighbours(self) -> np.ndarray:
        """Indices ``i`` where samples ``i`` and ``i + 1`` are of the same row."""
        return np.flatnonzero(self.row[1:] == self.row[:-1])


def _chunk(solver: _Solver, T: np.ndarray, grid: int) -> Q7Arcs:
    """:func:`q7_arcs` of at most :data:`_CHUNK` poses."""
    count = len(T)
    g = np.linspace(solver.range[0], solver.range[1], grid)
    q, inside = solver.all_branches(np.repeat(T, grid, axis=0), np.tile(g, count))
    q = q.reshape(count, grid, 8, 7).transpose(0, 2, 1, 3)  # (N, 8, G, 7)
    inside = inside.reshape(count, grid, 8).transpose(0, 2, 1)
    rows = np.repeat(np.arange(8 * count), grid)
    s = _Samples(rows, np.tile(g, 8 * count), inside.ravel(), q.reshape(-1, 7),
                 np.full(len(rows), -1))  # fmt: skip
    folds = _folds(solver, T, g, q, inside, s)
    s.sort()
    _refine(solver, T, s)
    _joint_turns(solver, T, s)
    _limit_ends(solver, T, s)
    s.sort()
    return _runs(solver, T, s, folds)


def _folds(solver: _Solver, T: np.ndarray, g: np.ndarray, q: np.ndarray, inside: np.ndarray,
           s: _Samples) -> int:  # fmt: skip
    """Find the folds between grid values (module docstring, step 2) and sample both
    branches there and on the way to it. Returns how many folds: the samples of the two
    sides of fold ``f`` are tagged ``2f`` and ``2f + 1``."""
    exists = np.isfinite(q[..., 0])
    change = exists[..., :-1] != exists[..., 1:]
    n, b, k = np.nonzero(change)
    side = np.where(exists[n, b, k], k, k + 1)  # where both exist

    def mate(x: np.ndarray) -> np.ndarray:  # a partner that vanishes there too
        return change[n, x, k] & exists[n, x, side]

    # the elbow's mate first when it vanishes too (every root ends: out of reach), else
    # the mate of step 3; then the other one where the first is no fold
    elbow = mate(b ^ 4)
    first, second = np.where(elbow, b ^ 4, b ^ 2), np.where(elbow, b ^ 2, b ^ 4)
    lead = (b & 1) == 0  # the shoulder's other sign (code b ^ 1) folds at the same q7
    done = np.zeros(change.shape, dtype=bool)
    tags = 0
    for partner in (first, second):
        fits = mate(partner) & (partner > b) & lead & ~done[n, b, k] & ~done[n, partner, k]
        at = (n[fits], b[fits], k[fits], side[fits], partner[fits])
        a, qa, ina, ok = _fold(solver, T, g, q, inside, at)
        fn, fb, fp, fa, fs = at[0][ok], at[1][ok], at[4][ok], a[ok], at[3][ok]
        done[fn, fb, at[2][ok]] = done[fn, fp, at[2][ok]] = True
        qa, ina = qa[ok], ina[ok]
        four = (fb, fp, fb ^ 1, fp ^ 1)  # the pair and its twin of the other shoulder
        for j, branch in enumerate(four):
            has = np.isfinite(qa[:, j, 0])
            tag = 2 * (tags + 2 * np.arange(len(fn)) + (j >= 2)) + j % 2  # fold, side
            s.add((fn * 8 + branch)[has], fa[has], qa[has, j], ina[has, j], tag[has])
        tags += 2 * len(fn)
        # samples evenly spaced in the curve's length from the grid value to the fold
        # (q7 moves as its square there): a joint may leave its limits and come back
        t = (np.arange(1, _EXTRA + 1) / (_EXTRA + 1)) ** 2
        x = (fa[:, None] + (g[fs] - fa)[:, None] * t).ravel()
        _sample(solver, T, np.repeat(fn, _EXTRA), x, s)
    return tags


def _sample(solver: _Solver, T: np.ndarray, pose: np.ndarray, x: np.ndarray, s: _Samples) -> None:
    """Add every branch that exists at poses ``pose`` and ``q7`` values ``x``."""
    every, within = solver.all_branches(T[pose], x)
    i, b = np.nonzero(np.isfinite(every[..., 0]))
    s.add(pose[i] * 8 + b, x[i], every[i, b], within[i, b])


def _evaluate(solver: _Solver, T: np.ndarray, pose: np.ndarray, x: np.ndarray, s: _Samples
              ) -> np.ndarray:  # fmt: skip
    """Every branch at the distinct ``(pose, x)`` pairs, added to ``s`` (unsorted); returns
    the configurations ``(M, 8, 7)`` of each pair asked (NaN: no such branch)."""
    key, back = np.unique(np.stack((pose, x), 1), axis=0, return_inverse=True)
    every, within = solver.all_branches(T[key[:, 0].astype(np.int64)], key[:, 1])
    i, b = np.nonzero(np.isfinite(every[..., 0]))
    s.add(key[i, 0].astype(np.int64) * 8 + b, key[i, 1], every[i, b], within[i, b])
    return every[back.ravel()]


def _refine(solver: _Solver, T: np.ndarray, s: _Samples) -> None:
    """Halve each step between neighbouring samples of a branch where a joint moves more
    than :data:`_JUMP`, and its halves again, until none does (or the step is
    :data:`_NARROW`): near the shoulder's singularity joints 1 and 3 swing through π in
    a stretch of ``q7`` that may be far shorter than the grid's step, and can pass
    outside their limits (through ±π) between two samples within them."""
    i = s.neighbours()
    i = i[np.abs(_wrap(s.q[i + 1] - s.q[i])).max(axis=1) > _JUMP]  # NaN: False
    row, xa, xb, qa, qb = s.row[i], s.x[i], s.x[i + 1], s.q[i], s.q[i + 1]
    added = False
    for _ in range(_LEVELS):
        keep = xb - xa > _NARROW
        row, xa, xb, qa, qb = row[keep], xa[keep], xb[keep], qa[keep], qb[keep]
        if not len(row):
            break
        mid = 0.5 * (xa + xb)
        qm = _evaluate(solver, T, row // 8, mid, s)[np.arange(len(row)), row % 8]
        added = True
        row = np.concatenate((row, row))
        xa, xb = np.concatenate((xa, mid)), np.concatenate((mid, xb))
        qa, qb = np.concatenate((qa, qm)), np.concatenate((qm, qb))
        jump = np.abs(_wrap(qb - qa)).max(axis=1) > _JUMP
        row, xa, xb, qa, qb = row[jump], xa[jump], xb[jump], qa[jump], qb[jump]
    if added:
        s.sort()


def _vertex(x: tuple[np.ndarray, ...], y: tuple[np.ndarray, ...]
            ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The vertex ``(x, y)`` of the parabola through three points (NaN where they are
    collinear or not distinct)."""
    x0, x1, x2 = x
    y0, y1, y2 = y
    with np.errstate(divide="ignore", invalid="ignore"):
        d01, d12 = (y1 - y0) / (x1 - x0), (y2 - y1) / (x2 - x1)
        curve = (d12 - d01) / (x2 - x0)
        vertex = 0.5 * (x0 + x1) - d01 / (2.0 * curve)
        value = y1 + (vertex - x1) * (d01 + curve * (vertex - x0))
    return vertex, value


def _turns(x: tuple[np.ndarray, ...], y: tuple[np.ndarray, ...]) -> np.ndarray:
    """Whether the function sampled at three points turns back between the outer two:
    the middle one is an extreme of the three (the slope changes sign), or the parabola
    through them has its vertex between the outer two and beyond the three values (a
    turn inside the first or last step of a run, where no sample lies past it)."""
    vertex, value = _vertex(x, y)
    inside = (vertex > x[0]) & (vertex < x[2])
    with np.errstate(invalid="ignore"):
        beyond = (value > np.maximum(np.maximum(y[0], y[1]), y[2])) | (
            value < np.minimum(np.minimum(y[0], y[1]), y[2]))  # fmt: skip
    return ((y[1] - y[0]) * (y[2] - y[1]) < 0.0) | (inside & beyond)


def _narrowed(px: np.ndarray, py: np.ndarray, x: np.ndarray, y: np.ndarray, top: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Of the three points ``(px, py)`` ``(M, 3)`` and a fourth ``(x, y)``, the three
    around the extreme (the largest where ``top``, else the smallest), in order of ``x``:
    a step of successive parabolic interpolation."""
    fx = np.concatenate((px, x[:, None]), axis=1)
    fy = np.concatenate((py, y[:, None]), axis=1)
    order = np.argsort(fx, axis=1)
    fx, fy = np.take_along_axis(fx, order, 1), np.take_along_axis(fy, order, 1)
    best = np.where(top, np.argmax(fy, axis=1), np.argmin(fy, axis=1))
    first = np.clip(best - 1, 0, 1)[:, None] + np.arange(3)
    return np.take_along_axis(fx, first, 1), np.take_along_axis(fy, first, 1)


def _joint_turns(solver: _Solver, T: np.ndarray, s: _Samples) -> None:
    """Sample each joint's turn near its limits (module docstring, step 4): where a
    joint's margin turns back between samples of a branch (:func:`_turns`) within
    :data:`_TURN_RANGE` of its limit, and the parabola through the three samples puts
    the turn across the limit or within :data:`_TURN_NEAR` of it, sample the vertex;
    then the parabola through the vertex and its two nearest (successive parabolic
    interpolation), until the turn is sampled to :data:`_TURN_TOL` in ``q7`` or found
    away from the limit, :data:`_TURN_ROUNDS` at most."""
    mid = np.flatnonzero((s.row[1:-1] == s.row[:-2]) & (s.row[1:-1] == s.row[2:])) + 1
    margins = solver.margins(s.q)
    y0, y1, y2 = margins[mid - 1], margins[mid], margins[mid + 1]  # NaN: no turn
    xs = tuple(np.broadcast_to(s.x[mid + d][:, None], y1.shape) for d in (-1, 0, 1))
    k, joint = np.nonzero(_turns(xs, (y0, y1, y2)) & (np.abs(y1) < _TURN_RANGE))
    px = np.stack([s.x[mid[k] + d] for d in (-1, 0, 1)], axis=1)
    py = np.stack([margins[mid[k] + d, joint] for d in (-1, 0, 1)], axis=1)
    row = s.row[mid[k]]
    top = _vertex(tuple(px.T), tuple(py.T))[1] > py[:, 1]
    active = np.arange(len(k))
    added = False
    for _ in range(_TURN_ROUNDS):
        x, value = _vertex(tuple(px[active].T), tuple(py[active].T))
        near = (np.sign(value) != np.sign(py[active, 1])) | (np.abs(value) < _TURN_NEAR)
        fresh = np.abs(px[active] - x[:, None]).min(axis=1) > _TURN_TOL
        ok = near & fresh & (x > px[active, 0]) & (x < px[active, 2])  # NaN: False
        active, x = active[ok], x[ok]
        if not len(active):
            break
        q = _evaluate(solver, T, row[active] // 8, x, s)[np.arange(len(x)), row[active] % 8]
        added = True
        y = solver.margins(q)[np.arange(len(x)), joint[active]]
        there = np.isfinite(y)  # the branch ends before the turn: a fold there
        active, x, y = active[there], x[there], y[there]
        px[active], py[active] = _narrowed(px[active], py[active], x, y, top[active])
    if added:
        s.sort()


def _fold(solver: _Solver, T: np.ndarray, g: np.ndarray, q: np.ndarray, inside: np.ndarray,
          at: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:  # fmt: skip
    """The secant on ``d²`` of pairs ``(pose, branch, interval, side, partner)`` from the
    side where both exist, bracketed by the other. Returns the ``q7`` reached, the
    configurations there of the pair and of its twin of the other shoulder sign (codes
    ``^ 1``; NaN where there is none) ``(F, 4, 7)``, whether each is within the limits,
    and whether the pair met (``d <`` :data:`FOLD_GAP`)."""
    n, b, k, side, partner = at
    grid = len(g)
    a, z = g[side], g[2 * k + 1 - side]
    back = np.clip(2 * side - (2 * k + 1 - side), 0, grid - 1)  # one grid value further
    four = (b, partner, b ^ 1, partner ^ 1)  # the pair, and its twin of the other shoulder
    qa = np.stack([q[n, x, side] for x in four], axis=1)
    da = _distance2(qa[:, 0], qa[:, 1])
    p = g[back]
    dp = _distance2(q[n, b, back], q[n, partner, back])  # NaN where either is missing
    ina = np.stack([inside[n, x, side] for x in four], axis=1)
    missed = np.zeros(len(a), dtype=bool)
    busy = (np.abs(z - a) > _FOLD_TOL) & (da > FOLD_GAP**2)
    while busy.any():
        act = np.flatnonzero(busy)
        with np.errstate(divide="ignore", invalid="ignore"):
            c = a[act] - da[act] * (a[act] - p[act]) / (da[act] - dp[act])
        # past the bracket (the secant's root is just past the fold): most of the way
        # to its end, or half-way after such a step missed
        secant = np.isfinite(c) & ((c - a[act]) * (z[act] - c) > 0.0)
        c = np.where(secant, c, a[act] + np.where(missed[act], 0.5, 0.9) * (z[act] - a[act]))
        every, within = solver.all_branches(T[n[act]], c)
        pick = np.arange(len(act))
        pair = np.stack([every[pick, x[act]] for x in four], axis=1)
        both = np.isfinite(pair[:, :2, 0]).all(axis=1)
        hit, miss = act[both], act[~both]
        p[hit], dp[hit] = a[hit], da[hit]
        a[hit], da[hit] = c[both], _distance2(pair[both, 0], pair[both, 1])
        qa[hit] = pair[both]
        ina[hit] = np.stack([within[pick, x[act]] for x in four], axis=1)[both]
        z[miss] = c[~both]
        missed[act] = ~both & ~secant
        busy[act] = (np.abs(z[act] - a[act]) > _FOLD_TOL) & (da[act] > FOLD_GAP**2)
    return a, qa, ina, da <= FOLD_GAP**2


def _branch(solver: _Solver, T: np.ndarray, q7: np.ndarray, branch: np.ndarray
            ) -> np.ndarray:  # fmt: skip
    """Branch ``branch[i]``'s configuration at pose ``T[i]`` and ``q7[i]`` (NaN: none)."""
    found, _ = solver.all_branches(T, q7)
    return found[np.arange(len(q7)), branch]


def _limit_ends(solver: _Solver, T: np.ndarray, s: _Samples) -> None:
    """Find where a joint meets its limit between neighbouring samples of a branch, one
    within the limits and one outside (module docstring, step 5), and add a sample
    there."""
    i = s.neighbours()
    i = i[(s.inside[i] != s.inside[i + 1]) & np.isfinite(s.q[i, 0]) & np.isfinite(s.q[i + 1, 0])]
    c_in, c_out = np.where(s.inside[i], i, i + 1), np.where(s.inside[i], i + 1, i)
    row = s.row[i]
    x_in, x_out = s.x[c_in], s.x[c_out]
    q_in = s.q[c_in]
    m_in, m_out = solver.margin(q_in), solver.margin(s.q[c_out])
    x_last, m_last = x_out.copy(), m_out.copy()  # the third point of the interpolation
    wide = np.abs(x_out - x_in)  # the bracket two steps ago
    busy = (np.abs(x_out - x_in) > END_TOL) & (m_in > END_TOL)
    pose, branch = row // 8, row % 8
    while busy.any():
        act = np.flatnonzero(busy)
        xi, xo = x_in[act], x_out[act]
        c = _inverse_quadratic((xi, x_out[act], x_last[act]), (m_in[act], m_out[act], m_last[act]))
        slow = np.abs(xo - xi) > 0.5 * wide[act]
        good = np.isfinite(c) & ((c - xi) * (xo - c) > 0.0) & ~slow
        c = np.where(good, c, 0.5 * (xi + xo))
        wide[act] = np.where(good, wide[act], np.abs(xo - xi))
        qc = _branch(solver, T[pose[act]], c, branch[act])
        mc = solver.margin(qc)
        ins = mc >= 0.0  # NaN (no branch): outside
        a_in, a_out = act[ins], act[~ins]
        x_last[a_in], m_last[a_in] = x_in[a_in], m_in[a_in]
        x_last[a_out], m_last[a_out] = x_out[a_out], m_out[a_out]
        x_in[a_in], m_in[a_in], q_in[a_in] = c[ins], mc[ins], qc[ins]
        x_out[a_out], m_out[a_out] = c[~ins], mc[~ins]
        busy[act] = (np.abs(x_out[act] - x_in[act]) > END_TOL) & (m_in[act] > END_TOL)
    s.add(row, x_in, q_in, np.ones(len(row), dtype=bool))


def _inverse_quadratic(x: tuple[np.ndarray, ...], y: tuple[np.ndarray, ...]) -> np.ndarray:
    """The root of the quadratic ``x(y)`` through three points (inverse quadratic
    interpolation, as in Brent's method); the secant of the first two where the values
    are not distinct or not finite; NaN where neither is defined."""
    x0, x1, x2 = x
    y0, y1, y2 = y
    with np.errstate(divide="ignore", invalid="ignore"):
        quad = (x0 * y1 * y2 / ((y0 - y1) * (y0 - y2)) + x1 * y0 * y2 / ((y1 - y0) * (y1 - y2))
                + x2 * y0 * y1 / ((y2 - y0) * (y2 - y1)))  # fmt: skip
        secant = x0 - y0 * (x0 - x1) / (y0 - y1)
    return np.asarray(np.where(np.isfinite(quad), quad, secant))


def _runs(solver: _Solver, T: np.ndarray, s: _Samples, folds: int) -> Q7Arcs:
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
    turn[1:] = _wrap(np.diff(phi))
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
        bridge = u[pairs] + _wrap(u[pairs[:, ::-1]] - u[pairs])  # the other side's angle
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


def _extrema(solver: _Solver, T: np.ndarray, row: np.ndarray, x: np.ndarray, u: np.ndarray,
             run: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """At each sample where the arm angle ``u`` turns back along its run, the arm angle at
    its turn: the vertex of the parabola through it and its neighbours, then through the
    vertex and its two nearest of them, :data:`_TURN_ROUNDS` at most (successive
    parabolic interpolation, to :data:`_TURN_TOL` in ``q7``); ``(run, angle)`` of each
    vertex within the limits."""
    mid = np.flatnonzero((run[1:-1] == run[:-2]) & (run[1:-1] == run[2:])) + 1
    mid = mid[_turns((x[mid - 1], x[mid], x[mid + 1]), (u[mid - 1], u[mid], u[mid + 1]))]
    if not len(mid):
        return np.zeros(0, np.int64), np.zeros(0)
    px = np.stack((x[mid - 1], x[mid], x[mid + 1]), axis=1)
    pu = np.stack((u[mid - 1], u[mid], u[mid + 1]), axis=1)
    top = _vertex(tuple(px.T), tuple(pu.T))[1] > pu[:, 1]  # a maximum
    pose, branch = row[mid] // 8, row[mid] % 8
    out_run, out_u = [], []
    active = np.arange(len(mid))
    for _ in range(_TURN_ROUNDS):
        vertex, _ = _vertex(tuple(px[active].T), tuple(pu[active].T))
        lo, hi = px[active, 0], px[active, 2]
        vertex = np.clip(np.where(np.isfinite(vertex), vertex, px[active, 1]), lo, hi)
        q = _branch(solver, T[pose[active]], vertex, branch[active])
        ok = solver.margin(q) >= 0.0
        active, vertex, q = active[ok], vertex[ok], q[ok]
        phi = solver.angle(q)
        value = pu[active, 1] + _wrap(phi - pu[active, 1])
        out_run.append(run[mid][active])
        out_u.append(value)
        moved = np.abs(vertex - px[active, 1]) > _TURN_TOL
        px[active], pu[active] = _narrowed(px[active], pu[active], vertex, value, top[active])
        active = active[moved]
        if not len(active):
            break
    return np.concatenate(out_run), np.concatenate(out_u)
