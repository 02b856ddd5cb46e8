"""Compiled closed-form answer of ``rr.ik`` (internal): the solution within the joint limits
nearest a first guess, at the first value of ``q7`` tried that has one
(:mod:`redres.ik.closed`).

Entry point and its call tree::

    nearest(arm, links, axes, kinds, T, q0, others, out) -> SOLVED, or a negative status
        _q7_kernels.solve_pose (each value of q7 in turn, until one gives a solution
        within the limits), _residual_kernels.errors (of the one returned)

``arm`` and ``links, axes, kinds`` as for :func:`._q7_kernels.solve_many`; ``T`` the
target pose ``(4, 4)``; ``q0`` the first guess ``(7,)``, rad; ``others`` the values of
``q7`` tried after ``q0[6]``, nearest to it first (at most 62), rad; ``out``
``(N_ROWS, N_VALUES)`` receives in row 0 the answer: joints clipped into the limits (a
solution is within them to ``LIMIT_TOL``; ``q0`` itself where it is the answer to
:data:`SAME_TOL` and within the limits), its FK errors, branch, flags. Statuses:
``BAD_POSE``, ``BAD_Q7`` (:mod:`._analytic_codes`), ``NONE_WITHIN_LIMITS`` (no value
gives a solution within the limits).
"""

from __future__ import annotations

import math

from .._compile import kernel
from ._analytic_codes import (
    COUNT_MASK,
    HI,
    LO,
    N_JOINTS,
    N_VALUES,
    NONE_WITHIN_LIMITS,
    SOLVED,
    WITHIN,
)
from ._q7_kernels import solve_pose
from ._residual_kernels import errors

SAME_TOL = 1e-9  # rad: an answer this near q0 (every joint) is q0 itself


@kernel(nogil=False)  # called from Python, a microsecond per value tried
def nearest(arm, links, axes, kinds, T, q0, others, out):
    """The nearest solution within the limits (module docstring) into ``out[0]``, trying
    ``q7 = q0[6]`` and then ``others`` nearest to it first; returns ``SOLVED`` or a
    negative status."""
    q7 = q0[6]
    tried = 0  # bit i: others[i] tried
    for k in range(others.shape[0] + 1):
        value = q7
        if k > 0:  # the nearest of the others not yet tried
            pick, gap = 0, math.inf
            for i in range(others.shape[0]):
                if not (tried >> i) & 1 and abs(others[i] - q7) < gap:
                    pick, gap = i, abs(others[i] - q7)
            tried |= 1 << pick
            value = others[pick]
        code = solve_pose(arm, T, value, out)
        if code < 0:
            return code
        best, best_d = -1, math.inf
        for r in range(code & COUNT_MASK):
            if out[r, WITHIN] == 1.0:
                d = 0.0  # squared Euclidean distance to q0, rad²
                for j in range(N_JOINTS):
                    d += (out[r, j] - q0[j]) ** 2
                if d < best_d:
                    best, best_d = r, d
        if best >= 0:
            for j in range(N_VALUES):
                out[0, j] = out[best, j]
            same = True  # q0 is the answer (to SAME_TOL), within the limits: q0 itself
            for j in range(N_JOINTS):  # within the limits to LIMIT_TOL: onto them
                out[0, j] = min(max(out[0, j], arm[LO + j]), arm[HI + j])
                same &= abs(out[0, j] - q0[j]) <= SAME_TOL
                same &= (arm[LO + j] <= q0[j]) & (q0[j] <= arm[HI + j])
            if same:  # as the iteration returns a q0 that meets the tolerances
                for j in range(N_JOINTS):
                    out[0, j] = q0[j]
            errors(links, axes, kinds, out, 1)
            return SOLVED
    return NONE_WITHIN_LIMITS
