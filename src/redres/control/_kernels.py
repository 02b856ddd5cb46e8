"""The compiled CLIK step of a frame task (internal): pose error (with the SO(3)
logarithm of :mod:`redres.robot._chain_kernels`), the rate step of
:mod:`redres.linalg._kernels`, velocity scaling and integration in one call, for the
controller's fast path. Compiled through
:mod:`redres._compile`; the ``config`` vector's layout is the ``CFG_*`` offsets of
:mod:`redres.linalg._codes`.

Each kernel comes in two forms: fed the frame's pose and Jacobian by Pinocchio
(:func:`clik_step`, :func:`frame_command`), or computing them itself from the frame's
serial chain with :mod:`redres.robot._chain_kernels` (:func:`chain_step`,
:func:`chain_command`), so that a step is one compiled call. Both then run the same
code on the same numbers."""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel
from ..linalg._codes import (
    CFG_DAMPING,
    CFG_DT,
    CFG_GAIN,
    CFG_HAS_GRAD,
    CFG_JOINTS,
    CFG_K_NULL,
    CFG_LIMIT,
    CFG_MAX_DAMPING,
    CFG_MODE,
    CFG_POSITION,
    CFG_RCOND,
    CFG_ROTATION,
    CFG_ROWS,
    CFG_THRESHOLD,
    CFG_TWIST,
    CFG_VECTORS,
    NO_WEIGHTS,
    OK,
    POSE_NONFINITE,
    Q_NONFINITE,
    Q_SHAPE,
)
from ..linalg._dense_kernels import _finite_1d, _finite_2d
from ..linalg._kernels import _step
from ..robot._chain_kernels import jacobian, rotation_error


@kernel
def _rows_at(config, n):
    """Offset of the task rows in ``config`` and their number ``m``; ``-1, 0`` when
    ``config`` is too short for them."""
    start = CFG_VECTORS + 3 * n
    if config.shape[0] < start:
        return -1, 0
    m = int(config[CFG_ROWS])
    if m < 0 or config.shape[0] < start + m:
        return -1, 0
    return start, m


@kernel
def frame_command(J, H, q, config, Jm, xd, e):
    """The frame-task part of :func:`clik_step` (alone: for schemes with their own step):
    ``e = [p_d - p; log(R_d R^T)]`` into ``e`` (6), the task rows of ``J`` into ``Jm``
    (m x n) and ``xd = twist_d + gain * e`` into ``xd`` (m). Returns a status."""
    n = q.shape[0]
    if J.shape[0] != 6 or J.shape[1] != n or H.shape[0] != 4 or H.shape[1] != 4:
        return Q_SHAPE
    rows, m = _rows_at(config, n)
    if rows < 0 or e.shape[0] != 6 or Jm.shape[0] != m or Jm.shape[1] != n or xd.shape[0] != m:
        return Q_SHAPE
    if not _finite_1d(q):
        return Q_NONFINITE
    return _frame_rows(J, H, config, rows, m, Jm, xd, e)


@kernel
def _frame_rows(J, H, config, rows, m, Jm, xd, e):
    """:func:`frame_command` past its checks of the shapes and of ``q``."""
    n = J.shape[1]
    if not _finite_2d(H):
        return POSE_NONFINITE
    for i in range(3):
        e[i] = config[CFG_POSITION + i] - H[i, 3]
    rotation_error(config[CFG_ROTATION : CFG_ROTATION + 9].reshape((3, 3)), H, e)
    for i in range(m):
        r = int(config[rows + i])
        xd[i] = config[CFG_TWIST + r] + config[CFG_GAIN + r] * e[r]
        for j in range(n):
            Jm[i, j] = J[r, j]
    return OK


@kernel
def _chain_kinematics(config, q, T, J):
    """``T`` (4x4) and ``J`` (6 x n) <- the frame's pose and world-aligned Jacobian from
    its serial chain (:func:`redres.robot._chain_kernels.jacobian`), which ``config``
    holds after the task rows (``links, axes, kinds`` of
    :attr:`redres.robot.chain.SerialChain.arrays`, flattened; ``CFG_JOINTS`` = k).
    Returns a status: ``Q_SHAPE`` when ``config`` does not hold a chain for ``n`` joints,
    ``Q_NONFINITE`` when ``q`` holds NaN or ±inf."""
    n = q.shape[0]
    rows, m = _rows_at(config, n)
    k = int(config[CFG_JOINTS])
    start = rows + m
    if rows < 0 or k < 0 or config.shape[0] != start + 16 * k + 12:
        return Q_SHAPE
    axes_at = start + 12 * (k + 1)
    links = config[start:axes_at].reshape((k + 1, 3, 4))
    axes = config[axes_at : axes_at + 3 * k].reshape((k, 3))
    if not jacobian(links, axes, config[axes_at + 3 * k :], q, False, T, J):
        return Q_NONFINITE
    return OK


@kernel
def chain_command(config, q, block, Jm, xd):
    """:func:`frame_command` with the frame's pose and Jacobian from its serial chain
    (:func:`_chain_kinematics`) instead of Pinocchio. ``block`` (``22 + 6 n``) receives
    ``[e (6) | T (4x4, row-major) | J (6 x n, row-major)]``. Returns a status."""
    n = q.shape[0]
    rows, m = _rows_at(config, n)
    if rows < 0 or block.shape[0] != 22 + 6 * n:
        return Q_SHAPE
    if Jm.shape[0] != m or Jm.shape[1] != n or xd.shape[0] != m:
        return Q_SHAPE
    T = block[6:22].reshape((4, 4))
    J = block[22:].reshape((6, n))
    status = _chain_kinematics(config, q, T, J)
    if status != OK:
        return status
    return _frame_rows(J, T, config, rows, m, Jm, xd, block[:6])


@kernel(nogil=False)  # called from Python, about a microsecond
def clik_step(J, H, q, config, q_next, out):
    """One fused CLIK step on a frame task: pose error, rate step, limits, integration.

    Inputs: ``J`` the frame's 6 x n world-aligned Jacobian, ``H`` its 4 x 4 placement,
    ``q`` (n,) and ``config`` laid out as the ``CFG_*`` offsets say, with ``a, r, qd_max``
    (n each) and the task rows (m, indices into ``[x, y, z, rx, ry, rz]``) from
    ``CFG_VECTORS`` on. Computes::

        e  = [p_d - p; log(R_d R^T)]                      (six rows)
        xd = twist_d + gain * e                          (the task rows)
        qd = J# xd - k_null (I - J# J) (a * (q - r))     (damping mode CFG_MODE)
        qd <- qd / max(1, max_j |qd_j| / qd_max_j)        (when CFG_LIMIT is 1)
        q+ = q + qd dt

    with the same floating-point operations as the composed step (the quadratic cost's
    gradient ``a * (q - r)``, the division by the speed ratio), so that both give the same
    bits where the inverse does. Writes ``q+`` into ``q_next`` (n) and the output block
    ``out`` (``7 n + 27``)::

        [qd (n) | rank, sigma_min, sigma_max, damping, speed (5)
         | e (6) | H (4x4, row-major) | J (6 x n, row-major)]

    where ``speed`` is ``max_j |qd_j| / qd_max_j`` before scaling (0 when limits are
    off); its tail from ``e`` on is :func:`chain_command`'s block. Returns a status.
    """
    n = q.shape[0]
    rows, m = _rows_at(config, n)
    if rows < 0 or out.shape[0] != 7 * n + 27 or q_next.shape[0] != n:
        return Q_SHAPE
    work = np.empty(m * n + m + n)  # Jm, xd, the cost's gradient: one allocation
    Jm = work[: m * n].reshape((m, n))
    xd = work[m * n : m * n + m]
    block = out[n + 5 :]
    status = frame_command(J, H, q, config, Jm, xd, block[:6])
    if status != OK:
        return status
    for i in range(4):
        for j in range(4):
            block[6 + 4 * i + j] = H[i, j]
    for i in range(6):
        for j in range(n):
            block[22 + n * i + j] = J[i, j]
    return _resolve(Jm, xd, work[m * n + m :], q, config, q_next, out)


@kernel(nogil=False)  # called from Python, about a microsecond
def chain_step(config, q, q_next, out):
    """:func:`clik_step` with the frame's pose and Jacobian from its serial chain (as
    :func:`chain_command`): the whole step without Pinocchio, in four arguments (each
    array argument costs its conversion on every call). Same outputs and status."""
    n = q.shape[0]
    rows, m = _rows_at(config, n)
    if rows < 0 or out.shape[0] != 7 * n + 27 or q_next.shape[0] != n:
        return Q_SHAPE
    work = np.empty(m * n + m + n)
    Jm = work[: m * n].reshape((m, n))
    xd = work[m * n : m * n + m]
    status = chain_command(config, q, out[n + 5 :], Jm, xd)
    if status != OK:
        return status
    return _resolve(Jm, xd, work[m * n + m :], q, config, q_next, out)


@kernel
def _resolve(Jm, xd, scratch, q, config, q_next, out):
    """The rest of :func:`clik_step` from the task rows ``Jm``, ``xd``: the rate step and
    velocity scaling into ``out[:n]``, the diagnostics into ``out[n:n+5]``, the
    integration into ``q_next``; ``scratch`` (n) holds the cost's gradient. Returns a
    status."""
    n = q.shape[0]
    has_grad = config[CFG_HAS_GRAD] != 0.0
    grad = scratch[:n] if has_grad else scratch[:0]
    if has_grad:
        for j in range(n):
            grad[j] = config[CFG_VECTORS + j] * (q[j] - config[CFG_VECTORS + n + j])
    qd = out[:n]
    status, rank, smin, smax, used = _step(
        Jm, xd, grad, qd, xd[:0], config[CFG_K_NULL], NO_WEIGHTS, xd[:0], Jm[:0, :0],
        int(config[CFG_MODE]), config[CFG_DAMPING], config[CFG_MAX_DAMPING],
        config[CFG_THRESHOLD], config[CFG_RCOND],
    )  # fmt: skip
    speed = 0.0
    if status == OK and config[CFG_LIMIT] != 0.0:
        limits = config[CFG_VECTORS + 2 * n : CFG_VECTORS + 3 * n]
        for j in range(n):
            speed = max(speed, abs(qd[j]) / limits[j])
        if speed > 1.0:
            for j in range(n):
                qd[j] /= speed
    diag = out[n : n + 5]
    diag[0] = rank
    diag[1] = smin
    diag[2] = smax
    diag[3] = used
    diag[4] = speed
    if status != OK:
        return status
    dt = config[CFG_DT]
    for j in range(n):
        q_next[j] = q[j] + qd[j] * dt
    return OK


@kernel
def integrate(q, qd, dt, out):
    """``out <- q + qd dt`` (one compiled call instead of two NumPy temporaries); returns
    whether every ``out[j]`` is finite."""
    finite = True
    for j in range(q.shape[0]):
        x = q[j] + qd[j] * dt
        out[j] = x
        if not math.isfinite(x):
            finite = False
    return finite
