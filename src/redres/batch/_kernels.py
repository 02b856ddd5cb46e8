"""Compiled batches (internal): per-item kernels over a leading axis, on all cores.

Each kernel runs the per-item kernels of :mod:`redres.robot._chain_kernels` (pose,
Jacobian) and :mod:`redres.linalg._kernels` (the rate step, ``_step``, the one behind
:func:`redres.linalg.rate_step`) on item ``i`` of arrays with a leading batch axis, in a
numba ``prange`` loop (``@kernel(parallel=True)``). Items are independent and every
item is computed by the same per-item code with the same arguments as the single call,
so the results do not depend on the number of threads and equal the single calls bit
for bit. The loop runs over chunks of :data:`CHUNK` items, each with its own scratch
(the frame pose, the Jacobian, the rate step's: ``_step_into``, the body of ``_step``),
so that nothing is allocated per item.

:func:`ik_solves` runs the compiled position IK of :mod:`redres.ik._kernels`
(``solve_packed``, the kernel behind :func:`redres.ik.ik`) on each item, with a fixed
budget of attempts instead of a clock, so that its results are deterministic.

Every kernel writes a per-item status (a status code of :mod:`redres.linalg._codes`;
``Q_NONFINITE`` for a configuration with NaN or ±inf) and never raises; :mod:`redres.batch`
turns the first nonzero one into an error naming the item.
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel, parallel_range
from ..ik._kernels import solve_packed
from ..ik._layout import (
    BEST_ORIENTATION,
    BEST_POSITION,
    CONVERGED,
    ERR_ORIENTATION,
    ERR_POSITION,
    N_OPTIONS,
    N_STATE,
)
from ..linalg._codes import OK, Q_NONFINITE
from ..linalg._kernels import _step_into, _step_scratch
from ..robot._chain_kernels import fk, jacobian

prange = parallel_range()

_NO_SPEND = 2**62  # solve_packed's iteration budget per call: none (no clock here)
#: Items per chunk of the parallel loop (its scratch is reused within a chunk).
CHUNK = 64


@kernel(parallel=True)
def poses(links, axes, kinds, q, T, status):
    """``T[i]`` (4x4) <- pose of the chain's frame at ``q[i]``, for every row of ``q``
    (N x n); ``status[i]`` <- ``OK`` or ``Q_NONFINITE``."""
    count = q.shape[0]
    for i in prange(count):
        status[i] = OK if fk(links, axes, kinds, q[i], T[i]) else Q_NONFINITE


@kernel(parallel=True)
def jacobians(links, axes, kinds, q, local, T, J, status):
    """``T[i]`` (4x4) and ``J[i]`` (6 x n) <- pose and Jacobian (world-aligned, or the
    frame's axes when ``local``) at ``q[i]``; ``status[i]`` as :func:`poses`."""
    count = q.shape[0]
    for i in prange(count):
        ok = jacobian(links, axes, kinds, q[i], local, T[i], J[i])
        status[i] = OK if ok else Q_NONFINITE


@kernel(parallel=True)
def rate_steps(links, axes, kinds, q, xd, grad, k_null, weights, spec, qd, rank, stats, status):
    """``qd[i]`` <- ``J# xd - k_null (I - J# J) grad`` with ``J`` the world-aligned
    Jacobian at ``q[i]`` (N x n), as ``_kernels._step`` computes it (its body,
    ``_step_into``, in the chunk's scratch): ``xd`` (N x 6, or
    1 x 6 for all items), ``grad`` (N x n, 1 x n for all, or 0 x n for none),
    ``weights = (wmode, wdiag, W)`` and ``spec = (dmode, lam, lam_max, eps, rcond)``, the
    arguments of ``_step``. ``rank[i]``, ``stats[i]`` <-
    ``(sigma_min, sigma_max, damping)`` and ``status[i]`` (a linalg code)."""
    count, n = q.shape
    wmode, wdiag, W = weights
    dmode, lam, lam_max, eps, rcond = spec
    chunks = (count + CHUNK - 1) // CHUNK
    for c in prange(chunks):
        T = np.empty((4, 4))
        J = np.empty((6, n))
        scratch = _step_scratch(6, n, wmode)
        none = np.empty(0)
        for i in range(c * CHUNK, min(count, (c + 1) * CHUNK)):
            if not jacobian(links, axes, kinds, q[i], False, T, J):
                status[i] = Q_NONFINITE
                continue
            x = xd[i] if xd.shape[0] > 1 else xd[0]
            if grad.shape[0] == 0:
                g = none
            else:
                g = grad[i] if grad.shape[0] > 1 else grad[0]
            code, r, smin, smax, used = _step_into(
                J, x, g, qd[i], none, k_null, wmode, wdiag, W, dmode, lam, lam_max, eps, rcond,
                scratch,
            )  # fmt: skip
            status[i] = code
            rank[i] = r
            stats[i, 0] = smin
            stats[i, 1] = smax
            stats[i, 2] = used


@kernel(parallel=True)
def ik_solves(
    links,
    axes,
    kinds,
    limits,
    targets,
    q0,
    options,
    rows,
    keys,
    attempts,
    q,
    errors,
    counts,
    status,
):
    """Position IK of every target: item ``i`` runs the attempts ``0 … attempts − 1`` of
    ``ik._kernels.solve_packed`` on ``targets[i]`` (N x 4 x 4) from ``q0[i]`` (``q0``
    N x n, or 1 x n for all) with the restart key ``keys[i]`` (int64), ``options`` and
    ``rows`` as ``solve_packed``'s (no preference). Every attempt that converges fills
    the next of the ``S = q.shape[1]`` slots: ``q[i, s]`` (N x S x n) and
    ``errors[i, s]`` (N x S x 2, position and orientation error); the search stops when
    the slots are full or the attempts spent. When none converged, slot 0 holds the best
    configuration found and its errors. ``counts[i]`` <- (solutions, attempts made,
    iterations); ``status[i]`` <- 0, or -1 when the target is not a homogeneous
    transform (nothing done). With ``S = 1`` this is :func:`redres.ik.ik`'s sequence of
    calls (attempt 0 draws nothing, so one key serves every attempt)."""
    count = targets.shape[0]
    n = limits.shape[1]
    slots = q.shape[1]
    chunks = (count + CHUNK - 1) // CHUNK
    for c in prange(chunks):
        problem = np.empty(16 + N_OPTIONS)
        io = np.empty(2 * n + N_STATE)
        for k in range(N_OPTIONS):
            problem[16 + k] = options[k]
        for i in range(c * CHUNK, min(count, (c + 1) * CHUNK)):
            for a in range(4):
                for b in range(4):
                    problem[4 * a + b] = targets[i, a, b]
            start = q0[i] if q0.shape[0] > 1 else q0[0]
            for j in range(n):
                io[j] = start[j]
            for k in range(N_STATE):
                io[2 * n + k] = math.inf
            found, attempt, iterations, code = 0, 0, 0, 0
            while attempt < attempts and found < slots:
                result, made, used = solve_packed(
                    links, axes, kinds, limits, problem, io, rows, False, keys[i], attempt,
                    attempts, _NO_SPEND,
                )  # fmt: skip
                if result < 0:
                    code = -1
                    break
                attempt += made
                iterations += used
                if result == CONVERGED:
                    for j in range(n):
                        q[i, found, j] = io[j]
                    errors[i, found, 0] = io[2 * n + ERR_POSITION]
                    errors[i, found, 1] = io[2 * n + ERR_ORIENTATION]
                    found += 1
            if found == 0:
                for j in range(n):
                    q[i, 0, j] = io[n + j]
                errors[i, 0, 0] = io[2 * n + BEST_POSITION]
                errors[i, 0, 1] = io[2 * n + BEST_ORIENTATION]
            counts[i, 0] = found
            counts[i, 1] = attempt
            counts[i, 2] = iterations
            status[i] = code
