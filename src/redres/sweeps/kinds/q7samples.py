"""Samples of each branch of the Panda's closed form along ``q7``, placed where the
redundancy map needs them (steps 3-5 of :mod:`redres.sweeps.kinds.q7arcs`: the shoulder's
swings, joints turning near their limits, the ends where a joint meets its limit; the
folds, step 2, are :mod:`.q7folds`'); :mod:`.q7arcs` turns the runs of samples within the
limits into arm-angle arcs (step 6).

Everything is on flat arrays over every pose of a chunk and every branch (row
``8 n + b``): each step evaluates the closed form (:func:`redres.ik.analytic.at_q7_batch`)
once for all the values of ``q7`` it needs at once.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ... import _compile, batch
from ...ik.analytic import analytic_arm, at_q7_batch
from ...tasks.arm_angle import ArmAngleTask, arm_angles

if TYPE_CHECKING:
    from ...robot import Robot

__all__ = [
    "END_TOL",
    "TURN_ROUNDS",
    "TURN_TOL",
    "BranchSolver",
    "Samples",
    "branch_at",
    "narrowed",
    "parabola_vertex",
    "turns",
    "wrap",
]

END_TOL = 1e-8  #: rad: a limit end's bracket in q7, or its margin
_JUMP = 0.5  # rad: a joint's move between samples above which the step is halved
_LEVELS = 48  # halvings at most (a swing narrower than 2**-48 of the grid step is one)
_NARROW = 1e-13  # rad: a step of q7 not halved further
_TURN_RANGE = 0.5  # rad: a joint's turns farther inside (or outside) its limits are left
_TURN_NEAR = 0.05  # rad: a turn estimated this near its limit is sampled
TURN_TOL = 1e-7  # rad: a turn with a sample this near its vertex is done
TURN_ROUNDS = 6  # rounds of successive parabolic interpolation at most
_SMALL = 4096  # evaluations below which one thread is faster than a parallel launch
_TWO_PI = 2.0 * math.pi


class BranchSolver:
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
        q, inside, _ = self.evaluate(T, q7)
        return q, inside

    def evaluate(self, T: np.ndarray, q7: np.ndarray) -> tuple[np.ndarray, ...]:
        """:meth:`all_branches`, and the arguments of the roots that decide which branch
        exists ``(M, 3)`` (``roots`` of :class:`redres.ik.analytic.IKSolutionsBatch`)."""
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
        return q, inside, found.roots

    def margin(self, q: np.ndarray) -> np.ndarray:
        """The smallest distance of joints 1-6 inside their limits, rad (negative outside,
        measured on the circle from the middle of the limits; NaN where ``q`` is NaN).
        Not ``q7``'s: the walk's parameter stays within its range, and at the range's ends
        its margin, 0, stopped the search for where another joint meets its limit."""
        q = self.centre[:6] + wrap(q[..., :6] - self.centre[:6])  # past π: wrapped
        return np.minimum(q - self.q_min[:6], self.q_max[:6] - q).min(axis=-1)

    def margins(self, q: np.ndarray) -> np.ndarray:
        """Each joint's distance inside its nearer limit, rad, ``(..., 7)`` (negative
        outside; :meth:`margin` is their smallest)."""
        q = self.centre + wrap(q - self.centre)
        return np.minimum(q - self.q_min, self.q_max - q)

    def angle(self, q: np.ndarray) -> np.ndarray:
        """Arm angles of configurations ``(M, 7)``, rad."""
        if not len(q):
            return np.zeros(0)
        threads = 1 if len(q) < _SMALL else None  # a parallel launch waits for its slowest
        s, e, w = (batch.fk(self.robot, q, f, threads=threads)[:, :3, 3]
                   for f in (self.task.shoulder, self.task.elbow, self.task.wrist))  # fmt: skip
        return arm_angles(s, e, w, self.task.reference)


def wrap(x: np.ndarray) -> np.ndarray:
    """Angles into ``[-π, π]`` (a third of the time of ``np.mod``)."""
    return np.asarray(x - _TWO_PI * np.round(x / _TWO_PI))


def distance2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Squared joint-space distance of configurations ``(..., 7)``, rad², each joint's
    difference wrapped into ``[-π, π]``."""
    return np.sum(wrap(a - b) ** 2, axis=-1)


class Samples:
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
        # (row, x) as one complex key (numbers sort by real, then imaginary part): a stable
        # sort (timsort) of samples mostly sorted already, a quarter of np.lexsort's time
        order = np.argsort(self.row + 1j * self.x, kind="stable")
        for key in self._KEYS:
            setattr(self, key, getattr(self, key)[order])

    def neighbours(self) -> np.ndarray:
        """Indices ``i`` where samples ``i`` and ``i + 1`` are of the same row."""
        return np.flatnonzero(self.row[1:] == self.row[:-1])


def _evaluate(solver: BranchSolver, T: np.ndarray, pose: np.ndarray, x: np.ndarray, s: Samples
              ) -> np.ndarray:  # fmt: skip
    """Every branch at the distinct ``(pose, x)`` pairs, added to ``s`` (unsorted); returns
    the configurations ``(M, 8, 7)`` of each pair asked (NaN: no such branch)."""
    key, back = np.unique(np.stack((pose, x), 1), axis=0, return_inverse=True)
    every, within = solver.all_branches(T[key[:, 0].astype(np.int64)], key[:, 1])
    i, b = np.nonzero(np.isfinite(every[..., 0]))
    s.add(key[i, 0].astype(np.int64) * 8 + b, key[i, 1], every[i, b], within[i, b])
    return every[back.ravel()]


def refine(solver: BranchSolver, T: np.ndarray, s: Samples) -> None:
    """Halve each step between neighbouring samples of a branch where a joint moves more
    than :data:`_JUMP`, and its halves again, until none does (or the step is
    :data:`_NARROW`): near the shoulder's singularity joints 1 and 3 swing through π in
    a stretch of ``q7`` that may be far shorter than the grid's step, and can pass
    outside their limits (through ±π) between two samples within them."""
    i = s.neighbours()
    i = i[np.abs(wrap(s.q[i + 1] - s.q[i])).max(axis=1) > _JUMP]  # NaN: False
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
        jump = np.abs(wrap(qb - qa)).max(axis=1) > _JUMP
        row, xa, xb, qa, qb = row[jump], xa[jump], xb[jump], qa[jump], qb[jump]
    if added:
        s.sort()


def parabola_vertex(x: tuple[np.ndarray, ...], y: tuple[np.ndarray, ...]
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


def turns(x: tuple[np.ndarray, ...], y: tuple[np.ndarray, ...]) -> np.ndarray:
    """Whether the function sampled at three points turns back between the outer two:
    the middle one is an extreme of the three (the slope changes sign), or the parabola
    through them has its vertex between the outer two and beyond the three values (a
    turn inside the first or last step of a run, where no sample lies past it)."""
    vertex, value = parabola_vertex(x, y)
    inside = (vertex > x[0]) & (vertex < x[2])
    with np.errstate(invalid="ignore"):
        beyond = (value > np.maximum(np.maximum(y[0], y[1]), y[2])) | (
            value < np.minimum(np.minimum(y[0], y[1]), y[2]))  # fmt: skip
    return ((y[1] - y[0]) * (y[2] - y[1]) < 0.0) | (inside & beyond)


def narrowed(px: np.ndarray, py: np.ndarray, x: np.ndarray, y: np.ndarray, top: np.ndarray
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


def joint_turns(solver: BranchSolver, T: np.ndarray, s: Samples) -> None:
    """Sample each joint's turn near its limits (:mod:`.q7arcs`, step 4): where a
    joint's margin turns back between samples of a branch (:func:`turns`) within
    :data:`_TURN_RANGE` of its limit, and the parabola through the three samples puts
    the turn across the limit or within :data:`_TURN_NEAR` of it, sample the vertex;
    then the parabola through the vertex and its two nearest (successive parabolic
    interpolation), until the turn is sampled to :data:`TURN_TOL` in ``q7`` or found
    away from the limit, :data:`TURN_ROUNDS` at most."""
    mid = np.flatnonzero((s.row[1:-1] == s.row[:-2]) & (s.row[1:-1] == s.row[2:])) + 1
    margins = solver.margins(s.q)
    y0, y1, y2 = margins[mid - 1], margins[mid], margins[mid + 1]  # NaN: no turn
    k, joint = np.nonzero(np.abs(y1) < _TURN_RANGE)  # then only those: a tenth of them
    xs = tuple(s.x[mid[k] + d] for d in (-1, 0, 1))
    ys = (y0[k, joint], y1[k, joint], y2[k, joint])
    turning = turns(xs, ys)
    k, joint = k[turning], joint[turning]
    px = np.stack([s.x[mid[k] + d] for d in (-1, 0, 1)], axis=1)
    py = np.stack([margins[mid[k] + d, joint] for d in (-1, 0, 1)], axis=1)
    row = s.row[mid[k]]
    top = parabola_vertex(tuple(px.T), tuple(py.T))[1] > py[:, 1]
    active = np.arange(len(k))
    added = False
    for _ in range(TURN_ROUNDS):
        x, value = parabola_vertex(tuple(px[active].T), tuple(py[active].T))
        near = (np.sign(value) != np.sign(py[active, 1])) | (np.abs(value) < _TURN_NEAR)
        fresh = np.abs(px[active] - x[:, None]).min(axis=1) > TURN_TOL
        ok = near & fresh & (x > px[active, 0]) & (x < px[active, 2])  # NaN: False
        active, x = active[ok], x[ok]
        if not len(active):
            break
        q = _evaluate(solver, T, row[active] // 8, x, s)[np.arange(len(x)), row[active] % 8]
        added = True
        y = solver.margins(q)[np.arange(len(x)), joint[active]]
        there = np.isfinite(y)  # the branch ends before the turn: a fold there
        active, x, y = active[there], x[there], y[there]
        px[active], py[active] = narrowed(px[active], py[active], x, y, top[active])
    if added:
        s.sort()


def branch_at(solver: BranchSolver, T: np.ndarray, q7: np.ndarray, branch: np.ndarray
            ) -> np.ndarray:  # fmt: skip
    """Branch ``branch[i]``'s configuration at pose ``T[i]`` and ``q7[i]`` (NaN: none)."""
    found, _ = solver.all_branches(T, q7)
    return found[np.arange(len(q7)), branch]


def limit_ends(solver: BranchSolver, T: np.ndarray, s: Samples) -> None:
    """Find where a joint meets its limit between neighbouring samples of a branch, one
    within the limits and one outside (:mod:`.q7arcs`, step 5), and add a sample
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
        qc = branch_at(solver, T[pose[act]], c, branch[act])
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
