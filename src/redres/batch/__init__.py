"""Batches: kinematics and the rate step of many configurations at once, on all cores.

Each function takes configurations with a leading batch axis, ``q`` of shape ``(N, n)``,
and gives for every row what the single call gives for that row:

* :func:`fk`: poses ``(N, 4, 4)``, as :meth:`redres.robot.SerialChain.fk`;
* :func:`jacobian`: geometric Jacobians ``(N, 6, n)``, world-aligned or local, as
  :meth:`~redres.robot.SerialChain.jacobian` (both to 1e-12 of :meth:`Robot.fk
  <redres.robot.Robot.fk>` and :meth:`Robot.jacobian <redres.robot.Robot.jacobian>`,
  which use Pinocchio);
* :func:`rate_step`: the joint velocities ``qd = J# xd − k_null N ∇D`` of
  :func:`redres.linalg.rate_step` with each row's world-aligned Jacobian, and the
  diagnostics of each inverse (:class:`BatchRateStep`);
* :func:`ik`: position IK of many targets (:class:`BatchIK`), each item what
  :func:`redres.ik.ik` finds with the same settings and restart key, under a budget of
  attempts and iterations instead of a clock (so the answers do not depend on load),
  optionally collecting several solutions per target.

They run one compiled kernel per call (:mod:`redres.batch._kernels`), a parallel loop
over the items that calls the same per-item kernels as the single calls, so the results
equal the single calls bit for bit and do not depend on the number of threads
(``threads=`` sets it for one call; default: all of numba's, ``NUMBA_NUM_THREADS``).
Calls from several Python threads take turns (numba's default thread pool is not
re-entrant); each uses all its threads.

The compiled kinematics are those of a serial chain (:mod:`redres.robot.chain`): a model
that is not one up to ``frame`` is refused with
:class:`~redres.robot.chain.NotSerialChainError` (loop over :meth:`Robot.jacobian
<redres.robot.Robot.jacobian>` for those). While the kernels compile behind on a cold
cache (:mod:`redres._compile`), under ``REDRES_DISABLE_JIT=1``, with the linalg kernels
switched off and for more than 50 joints, each function loops over the single calls
instead (same answers, much slower).

Errors name the offending item: a ragged or mis-shaped input raises
:class:`~redres.errors.ShapeError`, NaN or infinity :class:`~redres.errors.NonFiniteError`
(``"q[17] contains NaN or infinity"``).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from .. import _compile
from .._validate import FloatArray, as_scalar, as_seed, short_repr
from ..errors import InvalidParameterError, NonFiniteError, ShapeError
from ..linalg import RCOND, AdaptiveDamping, InverseInfo
from ..linalg import _backend as be
from ..linalg import _codes as codes
from ..linalg import _engine as eng
from ..linalg import _weights as wt
from ..linalg import rate_step as _single_rate_step
from ..linalg._status import raise_status
from ..robot import Reference, Robot, SerialChain
from ..robot.chain import _output  # the check of SerialChain's output arrays
from ._rows import _fits_in_memory, _keys, _rows, _targets, _typed

__all__ = ["BatchIK", "BatchRateStep", "fk", "ik", "jacobian", "rate_step"]

#: The batch kernels (parallel loops over the single calls' kernels). Cold: 53 s.
KERNELS = _compile.KernelGroup("batch", ("redres.batch._kernels",), cold_seconds=53.0)
_LOCK = threading.Lock()
#: The most solutions :func:`ik` seeks per target.
MAX_SOLUTIONS = 1024
_TASK_ROWS = 6  # rows of a frame Jacobian
# InverseInfo.method by damping mode (EXACT, FIXED, ADAPTIVE, SELECTIVE), as rate_step's.
_LABELS = tuple(eng.method_label(mode, False, "pinv") for mode in range(4))
_WEIGHTED_LABELS = tuple(eng.method_label(mode, True, "") for mode in range(4))


class BatchRateStep(NamedTuple):
    """The result of :func:`rate_step`: item ``i`` is :func:`redres.linalg.rate_step`'s
    ``qd`` and ``info`` for row ``i`` (:meth:`info` rebuilds the latter).

    Attributes:
        qd: joint velocities, ``(N, n)``, rad/s.
        rank: rank of each inverse (``int64``, ``(N,)``); -1 where it was not computed
            (:func:`rate_step` with ``return_info=False``).
        full_rank: ``rank == min(6, n)``, ``(N,)``.
        sigma_min: smallest singular value of each Jacobian, ``(N,)``; NaN where not
            computed.
        sigma_max: largest singular value, ``(N,)``; NaN where not computed.
        damping: damping applied to each item, ``(N,)`` (units of ``J``).
        method: the inverse, as :attr:`redres.linalg.InverseInfo.method`
            (``"pinv"``, ``"damped"``, ``"adaptive"``, ``"weighted-…"``).
    """

    qd: FloatArray
    rank: Any
    full_rank: Any
    sigma_min: FloatArray
    sigma_max: FloatArray
    damping: FloatArray
    method: str

    def info(self, i: int) -> InverseInfo:
        """The :class:`~redres.linalg.InverseInfo` of item ``i``."""
        return InverseInfo(
            int(self.rank[i]), bool(self.full_rank[i]), float(self.sigma_min[i]),
            float(self.sigma_max[i]), float(self.damping[i]), self.method,
        )  # fmt: skip


# ---------------------------------------------------------------------- public functions


def fk(robot: Robot, q: Any, frame: str | None = None, *, threads: int | None = None) -> FloatArray:
    """Poses of ``frame`` (default: tip) in the world at each row of ``q``.

    Args:
        robot: the robot (a serial chain up to ``frame``).
        q: configurations, ``(N, n)``, rad (m for prismatic joints).
        frame: a frame name of ``robot.frames()``; ``None`` for the tip.
        threads: threads for this call (``None``: all).

    Returns:
        ``(N, 4, 4)`` homogeneous transforms.

    Raises:
        ShapeError: ``q`` is ragged or not ``(N, n)`` (the message names the row).
        NonFiniteError: a row of ``q`` holds NaN or infinity (named).
        NotSerialChainError: the model is not a serial chain up to ``frame``.
    """
    chain = _chain(robot, frame)
    qs = _rows(q, "q", chain.n)
    T = np.empty((len(qs), 4, 4))
    kernels = _compiled(threads)
    if kernels is None:
        _loop(len(qs), lambda i: chain.fk(qs[i], out=T[i]), (qs, codes.Q_NONFINITE))
        return T
    status = np.empty(len(qs), dtype=np.int64)
    _launch(kernels.poses, (*chain.arrays, qs, T, status), threads)
    _check(status)
    return T


def jacobian(
    robot: Robot,
    q: Any,
    frame: str | None = None,
    reference: Reference = "world",
    *,
    poses: FloatArray | None = None,
    threads: int | None = None,
) -> FloatArray:
    """Geometric Jacobians of ``frame`` at each row of ``q``, ``(N, 6, n)``, rows
    ``[v; ω]``: world-aligned axes (``"world"``) or the frame's own (``"local"``), as
    :meth:`redres.robot.Robot.jacobian`. ``poses``, a writeable C-contiguous float64
    ``(N, 4, 4)`` array, receives the poses from the same pass (:func:`fk`'s). Other
    arguments and errors as :func:`fk`."""
    if reference not in ("world", "local"):
        raise InvalidParameterError(f"reference must be 'world' or 'local'; got {reference!r}")
    chain = _chain(robot, frame)
    qs = _rows(q, "q", chain.n)
    T = _output(poses, (len(qs), 4, 4), "poses")
    J = np.empty((len(qs), _TASK_ROWS, chain.n))
    kernels = _compiled(threads)
    if kernels is None:
        _loop(len(qs), lambda i: chain.kinematics(qs[i], reference, pose=T[i], jacobian=J[i]),
              (qs, codes.Q_NONFINITE))  # fmt: skip
        return J
    status = np.empty(len(qs), dtype=np.int64)
    _launch(kernels.jacobians, (*chain.arrays, qs, reference == "local", T, J, status), threads)
    _check(status)
    return J


def rate_step(
    robot: Robot,
    q: Any,
    xd: Any,
    grad: Any | None = None,
    *,
    frame: str | None = None,
    k_null: float = 1.0,
    damping: float | AdaptiveDamping = 0.0,
    weights: Any | None = None,
    rcond: float = RCOND,
    threads: int | None = None,
    return_info: bool = True,
) -> BatchRateStep:
    """The rate step ``qd = J# xd − k_null N grad`` of each row of ``q``, with ``J`` the
    world-aligned Jacobian of ``frame`` there: row ``i`` is
    ``redres.linalg.rate_step(robot.chain(frame).jacobian(q[i]), xd[i], grad[i], ...)``.

    Args:
        robot: the robot (a serial chain up to ``frame``).
        q: configurations, ``(N, n)``, rad.
        xd: task velocities ``[v; ω]``, ``(N, 6)``, or ``(6,)`` for every item (m/s, rad/s).
        grad: gradients of the secondary cost, ``(N, n)`` or ``(n,)`` for every item;
            ``None`` for none.
        frame: the task frame (default: tip).
        k_null, damping, weights, rcond: as :func:`redres.linalg.rate_step` (one value
            for all items).
        threads: threads for this call (``None``: all).
        return_info: ``False``: the singular values are not wanted, so that with a
            fixed damping ``λ > 0`` each step may skip them (the two extreme eigenvalues
            of ``J Jᵀ``, about half of a step) and solve ``(J Jᵀ + λ² I) y = xd`` by Cholesky
            at once whenever ``λ² >= 1e-6 trace(J Jᵀ)`` (then ``κ <= 1 + 1e6``, as
            accurate as the Cholesky path with them); those items report rank -1,
            ``full_rank`` False and NaN ``sigma_min``/``sigma_max`` (``damping`` is λ),
            and their ``qd`` equals the single call's bit for bit wherever that call
            takes the Cholesky path (``sigma_min >= 1e-3 sigma_max``), to about 1e-10
            relative nearer a singularity, where it uses an SVD. Other damping modes
            need the singular values to choose their factorisation and report them
            either way.

    Returns:
        A :class:`BatchRateStep`: ``qd (N, n)`` and each item's diagnostics.

    Raises:
        ShapeError: an input is ragged or of the wrong shape (the message names the row).
        NonFiniteError: a row of ``q``, ``xd`` or ``grad`` holds NaN or infinity (named).
        InvalidParameterError: negative ``damping`` or ``rcond``.
        NotPositiveDefiniteError: ``weights`` is not positive definite.
        NotSerialChainError: the model is not a serial chain up to ``frame``.
    """
    chain = _chain(robot, frame)
    n = chain.n
    qs = _rows(q, "q", n)
    count = len(qs)
    xs = _rows(xd, "xd", _TASK_ROWS, count)
    gs = np.empty((0, n)) if grad is None else _rows(grad, "grad", n, count)
    k, rc = as_scalar(k_null, "k_null"), eng.as_rcond(rcond)
    mode, lam, lam_max, eps = be.parse_damping(damping)
    wmode, wdiag, wfull = wt.parse_weights(weights, n, "weights")
    wdiag, wfull = _typed(wdiag), _typed(wfull)
    method = (_LABELS if weights is None else _WEIGHTED_LABELS)[mode]
    kernels = _compiled(threads)
    if kernels is None or be.use_fast_path(_TASK_ROWS, n) is None:
        options = {"k_null": k, "damping": damping, "weights": weights, "rcond": rc}
        return _rate_loop(chain, qs, xs, gs, options, method)
    qd, rank = np.empty((count, n)), np.zeros(count, dtype=np.int64)
    stats, status = np.zeros((count, 3)), np.zeros(count, dtype=np.int64)
    kmode = codes.LAZY if mode == codes.FIXED and not return_info else mode
    args = (*chain.arrays, qs, xs, gs, k, (wmode, wdiag, wfull), (kmode, lam, lam_max, eps, rc))
    _launch(kernels.rate_steps, (*args, qd, rank, stats, status), threads)
    _check(status, len(xs) > 1, len(gs) > 1)
    full = rank == min(_TASK_ROWS, n)
    return BatchRateStep(qd, rank, full, stats[:, 0], stats[:, 1], stats[:, 2], method)


class BatchIK(NamedTuple):
    """The result of :func:`ik`: item ``i`` answers target ``i``.

    Attributes:
        q: the first solution of each target, or the best configuration found when none
            converged, ``(N, n)``, rad (always within the limits).
        converged: whether a solution was found, ``(N,)``.
        restarts: random restarts used (attempts made − 1), ``(N,)``.
        iterations: CLIK iterations over all attempts, ``(N,)``.
        position_error: ``‖p_d − p(q)‖`` of ``q``, m, ``(N,)``.
        orientation_error: rotation angle of ``R_d R(q)ᵀ``, rad, ``(N,)`` (0 for
            position targets).
        solutions: the solutions in the order found, ``(N, S, n)``; slots past
            ``found[i]`` are NaN (slot 0 holds ``q`` when none converged).
        found: solutions found per target, ``(N,)``, at most ``S``.
    """

    q: FloatArray
    converged: Any
    restarts: Any
    iterations: Any
    position_error: FloatArray
    orientation_error: FloatArray
    solutions: FloatArray
    found: Any


def ik(
    robot: Robot,
    targets: Any,
    frame: str | None = None,
    *,
    q0: Any = None,
    seed: int = 0,
    keys: Any = None,
    solutions: int = 1,
    tol_position: float = 1e-6,
    tol_orientation: float = 1e-5,
    max_iterations: int = 100,
    max_restarts: int = 50,
    max_step: float = 0.5,
    k_limits: float = 0.1,
    damping: AdaptiveDamping | None = None,
    patience: int = 10,
    threads: int | None = None,
) -> BatchIK:
    """Position IK of every target, in one parallel compiled kernel.

    Item ``i`` is the iteration of :func:`redres.ik.ik` (same options, same kernel:
    attempt 0 from ``q0[i]``, then random restarts drawn by the counter-based generator
    under ``keys[i]``), with the budget ``max_restarts`` restarts of at most
    ``max_iterations`` iterations each and no clock: with ``solutions=1`` it equals
    ``rr.ik(robot, targets[i], q0=q0[i], seed=int(keys[i]), timeout_s=None, ...)`` (an
    integer seed is :func:`~redres.ik.ik`'s restart key). With ``solutions=S > 1`` the
    attempts go on after a success until ``S`` solutions are found or the budget is spent (restarts
    from random configurations may find the same solution again; see ``found``).

    Args:
        robot: the robot (a serial chain up to ``frame``).
        targets: poses ``(N, 4, 4)`` (``T_world_frame``), or positions ``(N, 3)``, m, for
            position-only targets.
        frame: the frame to place (default: tip).
        q0: first guesses, ``(N, n)`` or ``(n,)`` for all, rad (clipped into the limits);
            default ``robot.neutral()``.
        seed: when ``keys`` is None, the keys are ``default_rng(seed).integers(0, 2**62,
            N)``.
        keys: restart keys, ``(N,)`` integers in ``[0, 2**62)``.
        solutions: solutions sought per target (>= 1).
        tol_position, tol_orientation: as :func:`redres.ik.ik`.
        max_iterations, max_restarts, max_step, k_limits, damping, patience: as there.
        threads: threads for this call (``None``: all).

    Returns:
        A :class:`BatchIK`.

    Raises:
        ShapeError: ``targets`` is not ``(N, 4, 4)`` or ``(N, 3)``, an item is not a
            homogeneous transform (named), or ``q0``/``keys`` has the wrong shape.
        NonFiniteError: a target or ``q0`` holds NaN or infinity (named).
        InvalidParameterError: a tolerance, budget or gain out of range.
        NotSerialChainError: the model is not a serial chain up to ``frame``.
    """
    from ..ik.options import limit_arrays
    from ..ik.solve import _options_of

    chain = _chain(robot, frame)
    n = chain.n
    T, rows = _targets(targets)
    count = len(T)
    starts = _rows(robot.neutral() if q0 is None else q0, "q0", n, count)
    for name, array in (("targets", T.reshape(count, 16)), ("q0", starts)):
        bad = np.flatnonzero(~np.isfinite(array).all(axis=1))
        if bad.size:
            item = f"{name}[{bad[0]}]" if len(array) > 1 or name == "targets" else name
            raise NonFiniteError(f"{item} contains NaN or infinity")
    starts = _typed(np.clip(starts, robot.q_min, robot.q_max))
    if (
        isinstance(solutions, bool)
        or not isinstance(solutions, (int, np.integer))
        or not 1 <= solutions <= MAX_SOLUTIONS
    ):
        raise InvalidParameterError(
            f"solutions must be an integer from 1 to {MAX_SOLUTIONS}; got {short_repr(solutions)}"
        )
    o, packed, _ = _options_of(
        tol_position, tol_orientation, max_iterations, max_restarts, None, max_step,
        k_limits, damping, patience, 1e-5,
    )  # fmt: skip
    key = _keys(keys, as_seed(seed), count)
    _fits_in_memory(count * (int(solutions) * (n + 2) + 4) * 8, "rr.batch.ik")
    q = np.full((count, int(solutions), n), np.nan)
    errors = np.full((count, int(solutions), 2), np.nan)
    counts = np.zeros((count, 3), dtype=np.int64)
    status = np.zeros(count, dtype=np.int64)
    kernels = _compiled(threads)
    if kernels is None:
        kernels = KERNELS.module(plain=True)  # the plain-Python twin: the same code, slowly
    fixed = (*chain.arrays, limit_arrays(robot.q_min, robot.q_max))
    # In launches of a few thousand targets: Ctrl-C (KeyboardInterrupt) is seen between
    # two (a compiled call cannot be interrupted); each item depends on its own row alone.
    step = 4096
    for a in range(0, count, step):
        b = min(count, a + step)
        first = starts if len(starts) == 1 else starts[a:b]
        args = (*fixed, T[a:b], first, packed, rows, key[a:b], o.max_restarts + 1, q[a:b],
                errors[a:b], counts[a:b], status[a:b])  # fmt: skip
        _launch(kernels.ik_solves, args, threads)
    if status.any():
        i = int(np.flatnonzero(status)[0])
        raise ShapeError(f"targets[{i}] is not a homogeneous transform (orthonormal rotation "
                         "block with det +1, last row [0, 0, 0, 1])")  # fmt: skip
    found = counts[:, 0]
    return BatchIK(q[:, 0].copy(), found > 0, counts[:, 1] - 1, counts[:, 2],
                   errors[:, 0, 0].copy(), errors[:, 0, 1].copy(), q, found)  # fmt: skip


# ---------------------------------------------------------------------- helpers


def _chain(robot: Robot, frame: str | None) -> SerialChain:
    """The compiled serial chain of ``robot`` up to ``frame``; a clear error for anything
    that is not a :class:`~redres.robot.Robot`."""
    if not isinstance(robot, Robot):
        raise InvalidParameterError(
            f"robot must be a redres.Robot (e.g. rr.models.load('panda')); got {short_repr(robot)}"
        )
    return robot.chain(frame)


def _compiled(threads: int | None) -> Any:
    """The compiled batch kernels, or None: compiling behind, or plain Python (then the
    functions loop over the single calls, which are as fast as the plain kernels).
    Checks ``threads`` first, so that both paths refuse the same input."""
    if threads is not None and (
        isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1
    ):
        raise InvalidParameterError(
            f"threads must be a positive integer or None; got {short_repr(threads)}"
        )
    kernels = KERNELS.compiled()
    return kernels if kernels is not None and _compile.is_compiled(kernels) else None


def _launch(kernel: Any, args: tuple[Any, ...], threads: int | None) -> None:
    """Run a parallel kernel with ``threads`` threads (one launch at a time)."""
    with _LOCK:
        previous = _compile.threads(threads)
        try:
            kernel(*args)
        finally:
            _compile.threads(previous)


def _check(status: Any, per_xd: bool = True, per_grad: bool = True) -> None:
    """Raise the error of the first item whose status is not OK, naming the item."""
    bad = np.flatnonzero(status)
    if bad.size:
        i = int(bad[0])
        names = {"q": f"q[{i}]", "xd": f"xd[{i}]" if per_xd else "xd",
                 "grad": f"grad[{i}]" if per_grad else "grad", "W": "weights"}  # fmt: skip
        raise_status(int(status[i]), names)


def _loop(count: int, call: Callable[[int], object], *rows: tuple[FloatArray, int]) -> None:
    """The reference path: ``call(i)`` for each item, after the finiteness checks of the
    kernels on ``rows`` (``(array, status code)`` pairs), with the same messages."""
    status = np.zeros(count, dtype=np.int64)
    for array, code in reversed(rows):  # the first pair wins, as in the kernels
        if len(array):
            status[np.broadcast_to(~np.isfinite(array).all(axis=1), (count,))] = code
    _check(status, *(len(array) > 1 for array, _ in rows[1:]))
    for i in range(count):
        call(i)


def _rate_loop(
    chain: SerialChain,
    qs: FloatArray,
    xs: FloatArray,
    gs: FloatArray,
    options: dict[str, Any],
    method: str,
) -> BatchRateStep:
    """:func:`rate_step` as a loop over the single calls (the reference path)."""
    count, n = qs.shape
    qd, rank = np.empty((count, n)), np.zeros(count, dtype=np.int64)
    stats = np.zeros((count, 3))

    def item(i: int) -> None:
        J = chain.jacobian(qs[i])
        grad = None if not len(gs) else gs[i if len(gs) > 1 else 0]
        step = _single_rate_step(J, xs[i if len(xs) > 1 else 0], grad, **options)
        qd[i], rank[i] = step.qd, step.info.rank
        stats[i] = step.info.sigma_min, step.info.sigma_max, step.info.damping

    _loop(count, item, (qs, codes.Q_NONFINITE), (xs, codes.XD_NONFINITE),
          (gs, codes.GRAD_NONFINITE))  # fmt: skip
    full = rank == min(_TASK_ROWS, n)
    return BatchRateStep(qd, rank, full, stats[:, 0], stats[:, 1], stats[:, 2], method)
