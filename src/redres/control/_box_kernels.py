"""The compiled hard-limit steps of a frame task (internal): the front end of
:mod:`redres.control._kernels` (the frame's pose and Jacobian from its serial chain, the
pose error, ``ẋ``), the secondary velocity of diagonal quadratic costs, the joint-velocity
box and saturation in the null space (:mod:`redres.resolution.hard_limits`, the same
kernels :class:`~redres.resolution.SNSScheme` calls), and the integration, in one call.

Arrays (float64 unless said, C order): ``config`` as the fused kernels'
(:func:`redres.control._fused.fused_config` with the frame's chain); ``state``, kept from
step to step, laid out by :func:`state_size` (a header of settings, the limits
``lim`` (4, n), the previous velocity, the secondary velocity, the solver's workspaces,
the task rows ``Jm`` (m, n) and ``ẋ`` (m)); ``out``, a new one each step, laid out by
:func:`out_size`: ``[q̇ | null-space term | lower | upper (4 n) | J's task rows (m n) | e
(6) | T (16) | J (6 n)]``; ``codes`` (3, n) int8, a new one each step (bound kinds,
relaxed); ``wb`` (3, n) booleans.
"""

from __future__ import annotations

from .._compile import kernel
from ..linalg._codes import CFG_DT, CFG_HAS_GRAD, CFG_K_NULL, CFG_VECTORS, OK, Q_SHAPE
from ..resolution.hard_limits._kernels import sns_step
from ._kernels import _rows_at, chain_command

#: The header of ``state``: the SNS tolerance (rad/s), the QP's damping squared, whether
#: its exact QP was infeasible at the last step (1.0), the rows and columns of its
#: solvers' workspace (0 for SNS); then spare slots.
TOLERANCE, DAMPING2, INFEASIBLE, WORK_ROWS, WORK_COLS, HEADER = 0, 1, 2, 3, 4, 8


@kernel
def _rows_end(n, m):
    """Where the part of ``state`` that both steps use ends: the header, ``lim`` (4, n),
    ``q̇_0`` (n), ``M`` (3, m, m), ``wm`` (3, m), ``wn`` (6, n), ``Jm`` (m, n), ``ẋ`` (m)."""
    return HEADER + 5 * n + 3 * m * m + 3 * m + 6 * n + m * n + m


@kernel
def state_size(n, m, rows, cols):
    """Length of ``state`` for ``n`` joints and ``m`` task rows; ``rows``, ``cols``: the QP
    solvers' workspace (0, 0 for SNS)."""
    if rows == 0:
        return _rows_end(n, m)
    return _rows_end(n, m) + 2 * (n + m) + n + m + n * n + 3 * n + rows * cols


@kernel
def out_size(n, m):
    """Length of a step's ``out`` for ``n`` joints and ``m`` task rows."""
    return 4 * n + m * n + 22 + 6 * n


@kernel
def _views(state, n, m):
    """``(lim, q̇_0, M, wm, wn, Jm, ẋ)``: views of ``state`` (:func:`_rows_end`)."""
    k = HEADER
    lim = state[k : k + 4 * n].reshape((4, n))
    qd0 = state[k + 4 * n : k + 5 * n]
    k += 5 * n
    M = state[k : k + 3 * m * m].reshape((3, m, m))
    k += 3 * m * m
    wm = state[k : k + 3 * m].reshape((3, m))
    wn = state[k + 3 * m : k + 3 * m + 6 * n].reshape((6, n))
    k += 3 * m + 6 * n
    Jm = state[k : k + m * n].reshape((m, n))
    return lim, qd0, M, wm, wn, Jm, state[k + m * n : k + m * n + m]


@kernel
def _shapes_fit(q, prev, q_next, state, out, codes, flags, m):
    """Whether the arrays have the lengths and shapes the module docstring gives."""
    n = q.shape[0]
    if state.shape[0] < HEADER:
        return False
    size = state_size(n, m, int(state[WORK_ROWS]), int(state[WORK_COLS]))
    return (
        q_next.shape[0] == n
        and prev.shape[0] == n
        and state.shape[0] == size
        and out.shape[0] == out_size(n, m)
        and codes.shape[1] == n
        and flags.shape[1] == n
    )


@kernel
def _secondary(config, q, qd0):
    """``q̇_0 = −k_null a ∘ (q − r)`` of the config's quadratic costs into ``qd0``
    (:func:`redres.objectives.quadratic_coefficients`); returns whether there are any."""
    n = q.shape[0]
    if config[CFG_HAS_GRAD] == 0.0:
        return False
    k = -config[CFG_K_NULL]
    for j in range(n):
        qd0[j] = k * (config[CFG_VECTORS + j] * (q[j] - config[CFG_VECTORS + n + j]))
    return True


@kernel(nogil=False)  # called from Python, a few microseconds
def chain_sns_step(config, q, prev, q_next, state, out, codes, wb):
    """One SNS step of a frame task (module docstring): the chain's front end, the box,
    Algorithm 1 of Flacco, De Luca and Khatib (2015) with the linear program's check, and
    ``q⁺ = q + q̇ dt`` into ``q_next``, after the previous velocity ``prev`` (n). Returns
    the tuple of ``redres.resolution.hard_limits._kernels.sns_step``: ``(status, method,
    scale, #relaxed, #active, met, ill, full)``; when ``ill`` (the task is not met and
    ``J`` may be ill-conditioned) the caller finishes the step on the scheme's own path
    and integrates again."""
    n = q.shape[0]
    rows, m = _rows_at(config, n)
    if rows < 0 or not _shapes_fit(q, prev, q_next, state, out, codes, wb, m):
        return Q_SHAPE, 0, 0.0, 0, 0, False, False, False
    lim, qd0, M, wm, wn, Jm, xd = _views(state, n, m)
    box = out[: 4 * n].reshape((4, n))
    Jc = out[4 * n : 4 * n + m * n].reshape((m, n))
    status = chain_command(config, q, out[4 * n + m * n :], Jm, xd)
    if status != OK:
        return status, 0, 0.0, 0, 0, False, False, False
    use = _secondary(config, q, qd0)
    dt = config[CFG_DT]
    result = sns_step(q, prev, dt, lim, Jm, xd, qd0, use, state[TOLERANCE], box, codes, Jc,
                      M, wm, wn, wb)  # fmt: skip
    if result[0] == OK:
        for j in range(n):
            q_next[j] = q[j] + box[0, j] * dt
    return result
