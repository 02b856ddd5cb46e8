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
from ..resolution.hard_limits._codes import MET_TOLERANCE
from ..resolution.hard_limits._dense_qp_kernels import box_qp, eq_box_qp
from ..resolution.hard_limits._kernels import epilogue, sns_step
from ..resolution.hard_limits._qp_kernels import qp_begin, qp_end
from ._kernels import _rows_at, chain_command

#: The header of ``state``: the SNS tolerance (rad/s), the QP's damping squared, whether
#: its exact QP was infeasible at the last step (1.0), the rows and columns of its
#: solvers' workspace (0 for SNS); then spare slots.
TOLERANCE, DAMPING2, INFEASIBLE, WORK_ROWS, WORK_COLS, HEADER = 0, 1, 2, 3, 4, 8
_MET2 = MET_TOLERANCE * MET_TOLERANCE


@kernel
def _squared(x):
    """``‖x‖²``."""
    acc = 0.0
    for i in range(x.shape[0]):
        acc += x[i] * x[i]
    return acc


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
    ``q⁺ = q + q̇ dt`` into ``q_next``, after the previous velocity ``prev`` (n), which
    becomes ``q̇`` (unless ``ill``). Returns
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
            if not result[6]:
                prev[j] = box[0, j]
    return result


@kernel
def _qp_views(state, n, m):
    """The QP's part of ``state`` after the task rows: DAQP-style bounds ``bu``, ``bl``
    (n + m), ``f`` (n), the task weights ``w`` (m), the least-violating QP's ``P`` (n, n)
    and ``c`` (n), the exact and least-violating answers (warm starts) and the solvers'
    ``work`` (rows and columns in the header)."""
    k = _rows_end(n, m)
    bu = state[k : k + n + m]
    bl = state[k + n + m : k + 2 * (n + m)]
    k += 2 * (n + m)
    f, w = state[k : k + n], state[k + n : k + n + m]
    k += n + m
    P = state[k : k + n * n].reshape((n, n))
    k += n * n
    c, x, lv = state[k : k + n], state[k + n : k + 2 * n], state[k + 2 * n : k + 3 * n]
    k += 3 * n
    rows, cols = int(state[WORK_ROWS]), int(state[WORK_COLS])
    return bu, bl, f, w, P, c, x, lv, state[k : k + rows * cols].reshape((rows, cols))


@kernel(nogil=False)  # called from Python, a few microseconds
def chain_qp_step(config, q, prev, q_next, state, out, codes, act):
    """One QP step of a frame task (:mod:`redres.resolution.hard_limits.qp`, one level,
    no collision rows): the chain's front end, the box, the exact QP (Goldfarb–Idnani,
    :func:`~redres.resolution.hard_limits._dense_qp_kernels.eq_box_qp`) or, when it is
    infeasible, the least-violating one (a primal active set,
    :func:`~redres.resolution.hard_limits._dense_qp_kernels.box_qp`), in
    :class:`~redres.resolution.QPScheme`'s order: after an infeasible step the
    least-violating QP first, the exact one skipped when Farkas' lemma proves it
    infeasible; then ``q⁺ = q + q̇ dt``, and ``prev`` (the previous velocity, n) becomes
    ``q̇`` (unless ``defer``). ``act`` (2, n) int8: the two QPs' active sets,
    kept as warm starts. Returns ``(status, #relaxed, #active, met, residual, infeasible,
    defer)``: ``infeasible``, the exact QP was infeasible this step (the scheme's
    ``_infeasible_before`` next); ``defer``, a solver broke down or the answer needs the
    scheme's refinement on orthonormal rows (its residual exceeds ``MET_TOLERANCE``): the
    caller runs the scheme's own step on the task rows instead (nothing here changed
    the scheme's state)."""
    n = q.shape[0]
    rows, m = _rows_at(config, n)
    if rows < 0 or state.shape[0] < HEADER or state[WORK_ROWS] == 0.0:
        return Q_SHAPE, 0, 0, False, 0.0, False, False
    if not _shapes_fit(q, prev, q_next, state, out, codes, act, m):
        return Q_SHAPE, 0, 0, False, 0.0, False, False
    lim, qd0, M, wm, _, Jm, xd = _views(state, n, m)
    bu, bl, f, w, P, c, x, lv, work = _qp_views(state, n, m)
    box = out[: 4 * n].reshape((4, n))
    Jc = out[4 * n : 4 * n + m * n].reshape((m, n))
    status = chain_command(config, q, out[4 * n + m * n :], Jm, xd)
    if status != OK:
        return status, 0, 0, False, 0.0, False, False
    _secondary(config, q, qd0)
    dt = config[CFG_DT]
    status, relaxed, _, inside = qp_begin(q, prev, dt, lim, Jm, xd, qd0, box, codes, Jc, M,
                                             wm, bu, bl, f, w, state[DAMPING2], P, c)  # fmt: skip
    if status != OK:
        return status, 0, 0, False, 0.0, False, False
    before = state[INFEASIBLE] != 0.0
    infeasible, met, proved = before, True, False  # inside: the flag stays as it was
    active, residual = 0, 0.0
    if not inside:
        lo, hi = box[2], box[3]
        if before:  # the least-violating QP first; Farkas may prove the exact one empty
            if box_qp(P, c, lo, hi, lv, work, act[1])[0] != 1:
                return OK, relaxed, 0, False, 0.0, True, True
            proved, active, residual = qp_end(Jm, xd, lv, box, wm)
        if proved:
            infeasible, met = True, False
        else:
            flag = eq_box_qp(Jm, xd, qd0, lo, hi, x, work, act[0])[0]
            if flag < 0:
                return OK, relaxed, 0, False, 0.0, True, True
            infeasible = flag == 0
            if infeasible:
                met = False
                if not before:
                    if box_qp(P, c, lo, hi, lv, work, act[1])[0] != 1:
                        return OK, relaxed, 0, False, 0.0, True, True
                    proved, active, residual = qp_end(Jm, xd, lv, box, wm)
                if not proved:  # the scheme refines this one on orthonormal rows
                    return OK, relaxed, 0, False, 0.0, True, True
            else:
                for j in range(n):
                    box[0, j] = x[j]
    if not proved:
        active, residual = epilogue(Jm, xd, box, wm)
        if not inside and residual * residual > _MET2 * _squared(xd):
            return OK, relaxed, 0, False, 0.0, True, True  # the scheme's refinement
    for j in range(n):
        q_next[j] = q[j] + box[0, j] * dt
        prev[j] = box[0, j]
    return OK, relaxed, active, met, residual, infeasible, False
