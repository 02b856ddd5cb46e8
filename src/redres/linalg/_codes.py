"""Integer codes shared by the compiled kernels and their Python callers (internal).

Kept apart from :mod:`redres.linalg._kernels` so that callers can use them without
importing numba.
"""

from __future__ import annotations

from enum import IntEnum

#: Default relative rank tolerance: singular values ``<= RCOND * sigma_max`` count as zero
#: (:data:`redres.linalg.RCOND`; kernels compile it in).
RCOND = 1e-10


class Status(IntEnum):
    """What a kernel of :mod:`redres.linalg` returns (also the chain, batch and fused-step
    kernels, whose codes follow from ``Q_NONFINITE``): 0 = success, else the input it
    refused, named in the error :func:`redres.linalg._status.raise_status` raises."""

    OK = 0
    J_NONFINITE = 1
    XD_NONFINITE = 2
    GRAD_NONFINITE = 3
    W_NONFINITE = 4
    W_NOT_SPD = 5
    W_ASYMMETRIC = 6
    XD_SHAPE = 7
    GRAD_SHAPE = 8
    W_SHAPE = 9
    J_EMPTY = 10
    SCALAR_INVALID = 11  # k_null, damping or rcond of the fast lane (rate_step says which)
    XD_TOO_LARGE = 12
    Q_NONFINITE = 16
    Q_SHAPE = 17
    POSE_NONFINITE = 18


#: The same values as plain ints, which the kernels compile in.
(OK, J_NONFINITE, XD_NONFINITE, GRAD_NONFINITE, W_NONFINITE, W_NOT_SPD, W_ASYMMETRIC,
 XD_SHAPE, GRAD_SHAPE, W_SHAPE, J_EMPTY, SCALAR_INVALID, XD_TOO_LARGE, Q_NONFINITE, Q_SHAPE,
 POSE_NONFINITE) = (int(code) for code in Status)  # fmt: skip

#: Bound on the entries of a task velocity ``xd`` (a ``RedresError`` beyond): far above any
#: physical rate, and low enough that ``J# xd`` cannot overflow for any Jacobian the kernels
#: invert with the default ``rcond`` (``|J#| <= 1 / (rcond * TINY_SCALE)`` = 1e210).
MAX_TASK_RATE = 1e50
#: A matrix whose largest absolute entry is below this counts as zero (rank 0, ``J# = 0``):
#: the inverse of subnormal entries (5e-324) is not representable, and its damped inverse is
#: zero to within ``TINY_SCALE / damping**2``.
TINY_SCALE = 1e-200

# Damping modes.
EXACT = 0
FIXED = 1
ADAPTIVE = 2
SELECTIVE = 3
# FIXED when nobody reads the singular values (a controller's own loop, ``damped_pinv``
# without ``return_info``): the kernels may then skip them (rank -1, sigma NaN).
LAZY = 4

# Weight modes.
NO_WEIGHTS = 0
DIAGONAL = 1
FULL = 2

# Layout of the ``config`` vector of ``redres.control._kernels`` (n joints, m task rows, k
# chain joints): target rotation (row-major), target position, feedforward twist, per-row
# gain, then the scalars (CFG_ROWS = m, CFG_JOINTS = k), then from CFG_VECTORS on the
# quadratic cost coefficients a, r and the velocity limits (n each), the task rows (m) and,
# for the chain kernels, the frame's serial chain: links (12 (k + 1)), axes (3 k), kinds (k).
CFG_ROTATION = 0
CFG_POSITION = 9
CFG_TWIST = 12
CFG_GAIN = 18
CFG_K_NULL = 24
CFG_DAMPING = 25
CFG_MAX_DAMPING = 26
CFG_THRESHOLD = 27
CFG_MODE = 28
CFG_DT = 29
CFG_RCOND = 30
CFG_LIMIT = 31
CFG_HAS_GRAD = 32
CFG_ROWS = 33
CFG_JOINTS = 34
CFG_VECTORS = 35
