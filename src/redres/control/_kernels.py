"""The compiled CLIK step of a frame task (internal): pose error with its own SO(3)
logarithm, the rate step of :mod:`redres.linalg._kernels`, velocity scaling and
integration in one call, for the controller's fast path. Compiled through
:mod:`redres._jit`; the ``config`` vector's layout is the ``CFG_*`` offsets of
:mod:`redres.linalg._codes`."""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel
from ..linalg._codes import (
    CFG_DAMPING,
    CFG_DT,
    CFG_GAIN,
    CFG_HAS_GRAD,
    CFG_K_NULL,
    CFG_LIMIT,
    CFG_MAX_DAMPING,
    CFG_MODE,
    CFG_POSITION,
    CFG_RCOND,
    CFG_ROTATION,
    CFG_THRESHOLD,
    CFG_TWIST,
    CFG_VECTORS,
    NO_WEIGHTS,
    OK,
    POSE_NONFINITE,
    Q_NONFINITE,
    Q_SHAPE,
)
from ..linalg._dense_kernels import _finite_1d
from ..linalg._kernels import _step


@kernel
def _so3_log(M, out):  # type: ignore[no-untyped-def]
    """``out[:3] <- log(M)`` for a rotation matrix M: the rotation vector ``theta u``.

    ``theta = atan2(sin, cos)`` from the skew and trace parts, accurate at every angle;
    below ``cos = -0.9`` (``theta > 2.69``) the axis comes from the symmetric part
    ``(M + M^T)/2 - cos I = (1 - cos) u u^T`` (its largest diagonal entry), with the sign
    of the skew part, since ``sin`` alone loses the axis near ``pi``.
    """
    wx = M[2, 1] - M[1, 2]
    wy = M[0, 2] - M[2, 0]
    wz = M[1, 0] - M[0, 1]
    s = 0.5 * math.sqrt(wx * wx + wy * wy + wz * wz)
    c = 0.5 * (M[0, 0] + M[1, 1] + M[2, 2] - 1.0)
    theta = math.atan2(s, c)
    if c > -0.9:
        # theta / (2 sin theta), by its series where sin theta is tiny (theta < 1e-4).
        f = 0.5 * theta / s if s > 1e-4 else 0.5 + theta * theta / 12.0
        out[0] = f * wx
        out[1] = f * wy
        out[2] = f * wz
        return
    one_minus_c = 1.0 - c
    k = 0
    for i in range(1, 3):
        if M[i, i] > M[k, k]:
            k = i
    bkk = M[k, k] - c
    norm = math.sqrt(bkk * one_minus_c)
    skew = (wx, wy, wz)
    sign = 0.0
    for i in range(3):
        u = (0.5 * (M[i, k] + M[k, i]) - (c if i == k else 0.0)) / norm
        out[i] = u
        sign += u * skew[i]
    f = -theta if sign < 0.0 else theta
    for i in range(3):
        out[i] *= f


@kernel
def frame_command(J, H, q, rows, config, Jm, xd, e):  # type: ignore[no-untyped-def]
    """The frame-task part of :func:`clik_step` (alone: for schemes with their own step):
    ``e = [p_d - p; log(R_d R^T)]`` into ``e`` (6), the task rows of ``J`` into ``Jm``
    (m x n) and ``xd = twist_d + gain * e`` into ``xd`` (m). Returns a status."""
    n = q.shape[0]
    if J.shape[0] != 6 or J.shape[1] != n or H.shape[0] != 4 or H.shape[1] != 4:
        return Q_SHAPE
    if config.shape[0] != CFG_VECTORS + 3 * n or e.shape[0] != 6:
        return Q_SHAPE
    m = rows.shape[0]
    if Jm.shape[0] != m or Jm.shape[1] != n or xd.shape[0] != m:
        return Q_SHAPE
    if not _finite_1d(q):
        return Q_NONFINITE
    bad = 0.0
    for i in range(3):
        for j in range(4):
            bad += H[i, j] * 0.0
    if bad != 0.0:
        return POSE_NONFINITE
    M = np.empty((3, 3))
    for i in range(3):
        e[i] = config[CFG_POSITION + i] - H[i, 3]
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += config[CFG_ROTATION + 3 * i + k] * H[j, k]
            M[i, j] = acc
    _so3_log(M, e[3:])
    for i in range(m):
        r = rows[i]
        xd[i] = config[CFG_TWIST + r] + config[CFG_GAIN + r] * e[r]
        for j in range(n):
            Jm[i, j] = J[r, j]
    return OK


@kernel
def clik_step(J, H, q, rows, config, out):  # type: ignore[no-untyped-def]
    """One fused CLIK step on a frame task: pose error, rate step, limits, integration.

    Inputs: ``J`` the frame's 6 x n world-aligned Jacobian, ``H`` its 4 x 4 placement,
    ``q`` (n,), ``rows`` the task rows (indices into ``[x, y, z, rx, ry, rz]``) and
    ``config`` laid out as the ``CFG_*`` offsets say, with ``a, r, qd_max`` (n each) from
    ``CFG_VECTORS`` on. Computes::

        e  = [p_d - p; log(R_d R^T)]                      (six rows)
        xd = twist_d + gain * e                          (the selected rows)
        qd = J# xd - k_null (I - J# J) (a * (q - r))     (damping mode CFG_MODE)
        qd <- qd / max(1, max_j |qd_j| / qd_max_j)        (when CFG_LIMIT is 1)
        q+ = q + qd dt

    with the same floating-point operations as the composed step (the quadratic cost's
    gradient ``a * (q - r)``, the division by the speed ratio), so that both give the same
    bits where the inverse does; writes ``out[:n] = q+``, ``out[n:2n] = qd``,
    ``out[2n:2n+6] = e``. Returns ``(status, rank, sigma_min, sigma_max, damping, speed)``
    where ``speed`` is ``max_j |qd_j| / qd_max_j`` before scaling (0 when limits are off).
    """
    n = q.shape[0]
    m = rows.shape[0]
    if out.shape[0] != 2 * n + 6:
        return Q_SHAPE, 0, 0.0, 0.0, 0.0, 0.0
    Jm = np.empty((m, n))
    xd = np.empty(m)
    status = frame_command(J, H, q, rows, config, Jm, xd, out[2 * n : 2 * n + 6])
    if status != OK:
        return status, 0, 0.0, 0.0, 0.0, 0.0
    has_grad = config[CFG_HAS_GRAD] != 0.0
    grad = np.empty(n if has_grad else 0)
    if has_grad:
        for j in range(n):
            grad[j] = config[CFG_VECTORS + j] * (q[j] - config[CFG_VECTORS + n + j])
    qd = out[n : 2 * n]
    status, rank, smin, smax, used = _step(
        Jm, xd, grad, qd, xd[:0], config[CFG_K_NULL], NO_WEIGHTS, xd[:0], Jm[:0, :0],
        int(config[CFG_MODE]), config[CFG_DAMPING], config[CFG_MAX_DAMPING],
        config[CFG_THRESHOLD], config[CFG_RCOND],
    )  # fmt: skip
    if status != OK:
        return status, rank, smin, smax, used, 0.0
    speed = 0.0
    if config[CFG_LIMIT] != 0.0:
        limits = config[CFG_VECTORS + 2 * n : CFG_VECTORS + 3 * n]
        for j in range(n):
            speed = max(speed, abs(qd[j]) / limits[j])
        if speed > 1.0:
            for j in range(n):
                qd[j] /= speed
    dt = config[CFG_DT]
    for j in range(n):
        out[j] = q[j] + qd[j] * dt
    return OK, rank, smin, smax, used, speed


@kernel
def integrate(q, qd, dt, out):  # type: ignore[no-untyped-def]
    """``out <- q + qd dt`` (one compiled call instead of two NumPy temporaries); returns
    whether every ``out[j]`` is finite."""
    finite = True
    for j in range(q.shape[0]):
        x = q[j] + qd[j] * dt
        out[j] = x
        if not math.isfinite(x):
            finite = False
    return finite
