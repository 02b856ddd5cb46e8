"""The controller's one-call step for the hard-limit schemes (internal).

On a plain frame task whose frame ends a serial chain, a plain
:class:`~redres.resolution.SNSScheme` or :class:`~redres.resolution.QPScheme` (one level,
no collision rows, DAQP as its backend) whose objectives are diagonal quadratics
(joint-limit mid-range, posture) or none runs front end, box, resolution and integration
in one compiled call (:mod:`redres.control._box_kernels`), where the frame path calls the
front end's kernel and then the scheme's ``_step`` in Python. SNS runs the same kernels on
the same numbers, so the two give the same bits; the QP's two problems are solved by the
compiled solvers of :mod:`redres.resolution.hard_limits._dense_qp_kernels` instead of DAQP
(the same optimum to rounding), and where one of them breaks down or the answer needs the
scheme's refinement, the scheme's own step takes over on the kernel's task rows. The
scheme stays the owner of its state (``qd_prev``, the QP's last verdict) and of the step's
result (``_finished``). :func:`box_step` says whether a controller can take it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray
from ..linalg import _codes as codes
from ..objectives import quadratic_coefficients
from ..resolution import QPScheme, SNSScheme, StepResult
from ..resolution.hard_limits._dense_qp_kernels import work_shape
from ._fused import KERNELS, raise_for_status

if TYPE_CHECKING:
    from ..robot import Robot

_MODULE = "_box_kernels"
#: A step's result, or a function that builds it when it is first read.
Result = StepResult | Callable[[], StepResult]
_int8 = np.int8
_empty = np.empty


class BoxStep:
    """A hard-limit scheme's step on a frame task in one compiled call (module docstring).

    Args:
        robot: the robot.
        scheme: the scheme (its settings are read once, here).
        config: the controller's kernel config (with the frame's chain); its cost slots
            are set here from the scheme's objectives.
        quadratic: the objectives' ``(a, r)`` (:func:`redres.objectives.quadratic_coefficients`).
    """

    def __init__(
        self,
        robot: Robot,
        scheme: SNSScheme | QPScheme,
        config: FloatArray,
        quadratic: tuple[FloatArray, FloatArray] | None,
    ) -> None:
        n, m = robot.n, int(config[codes.CFG_ROWS])
        kernels = KERNELS.module(_MODULE)
        assert kernels is not None  # box_step found them
        self._robot, self._scheme, self._config = robot, scheme, config
        assert scheme.dt is not None  # a hard-limit scheme plans over its period
        self._n, self._m, self._dt = n, m, scheme.dt
        if quadratic is not None:
            v = codes.CFG_VECTORS
            config[codes.CFG_K_NULL] = scheme.k_null
            config[codes.CFG_HAS_GRAD] = 1.0
            config[v : v + n], config[v + n : v + 2 * n] = quadratic
        self._qp = qp = isinstance(scheme, QPScheme)
        rows, cols = work_shape(n, m) if qp else (0, 0)
        self._state = state = np.zeros(kernels.state_size(n, m, rows, cols))
        self._out_size = kernels.out_size(n, m)
        limits = scheme.limits(robot)
        head, end = kernels.HEADER, kernels._rows_end(n, m)
        state[kernels.WORK_ROWS], state[kernels.WORK_COLS] = rows, cols
        state[head : head + 4 * n] = np.concatenate(
            [limits.q_min, limits.q_max, limits.qd_max, limits.qdd_max]
        )
        self._Jm, self._xd = state[end - m * n - m : end - m].reshape(m, n), state[end - m : end]
        if isinstance(scheme, QPScheme):  # ``w``: after the bounds and ``f`` (_qp_views)
            state[kernels.DAMPING2] = scheme.damping * scheme.damping
            weights = scheme.task_weights
            state[end + 2 * (n + m) + n : end + 2 * (n + m) + n + m] = (
                1.0 if weights is None else weights
            )
        else:
            state[kernels.TOLERANCE] = scheme.tolerance
        self._flags = np.zeros((2, n), np.int8) if qp else np.zeros((3, n), np.bool_)
        self._prev = np.zeros(n)  # the scheme's qd_prev from the first step on
        self._shape, self._tail = (3, n), 4 * n + m * n
        name = "chain_qp_step" if qp else "chain_sns_step"
        entry = KERNELS.entry(name, self._arguments(np.zeros(n), np.empty(n)), _MODULE)
        self._prev[:] = 0.0  # (the warm-up call wrote its q̇)
        assert entry is not None  # numba imports: box_step found the kernels
        self._entry: Any = entry
        self._infeasible = kernels.INFEASIBLE  # the scheme's verdict, set at each step

    def _arguments(self, q: FloatArray, q_next: FloatArray) -> tuple[Any, ...]:
        """The kernel's arguments for a step at ``q`` (and a new ``out``, ``codes``)."""
        return (self._config, q, self._prev, q_next, self._state, _empty(self._out_size),
                _empty(self._shape, _int8), self._flags)  # fmt: skip

    def __call__(self, q: FloatArray) -> tuple[FloatArray, Result, FloatArray, FloatArray, Any]:
        """The step at ``q`` (float64, C order): ``(q⁺, the scheme's result or a function
        that builds it, q̇, the frame's error (6,), its pose (4, 4))``.

        The scheme's ``qd_prev`` is this step's array, which the kernel overwrites with
        ``q̇``; one the scheme set otherwise (a reset, its own step in between) is copied
        in first."""
        scheme, n = self._scheme, self._n
        prev = self._prev
        if scheme.qd_prev is not prev:
            held = scheme.qd_prev
            prev[:] = 0.0 if held is None else held
            scheme.qd_prev = prev
        if self._qp:  # the scheme's last verdict (its own state: a reset clears it)
            self._state[self._infeasible] = scheme._infeasible_before  # type: ignore[union-attr]
        q_next = _empty(n)
        args = self._arguments(q, q_next)
        status, *outcome = self._entry(*args)
        if status:
            raise_for_status(status, n)
        out, codes_, tail = args[5], args[6], self._tail
        error, pose = out[tail : tail + 6], out[tail + 6 : tail + 22].reshape(4, 4)
        if self._qp and not outcome[-1]:
            scheme._infeasible_before = outcome[4]  # type: ignore[union-attr]
        elif self._qp or outcome[5]:  # the scheme's own step, or its LP on orthonormal rows
            result = self._finish(q, q_next, out, codes_, outcome)
            return q_next, result, result.qd, error, pose
        return q_next, lambda: self._finish(q, q_next, out, codes_, outcome), out[:n], error, pose

    def _finish(
        self, q: FloatArray, q_next: FloatArray, out: FloatArray, codes_: Any, outcome: list[Any]
    ) -> StepResult:
        """The scheme's result of a step from the kernel's ``outcome`` (when first read);
        at once where the scheme finishes the step itself: SNS's LP on orthonormal rows
        (``ill``; then ``q̇`` may change and ``q⁺`` is integrated again), a QP step the
        kernel handed back (``defer``: the scheme's own step on the kernel's task rows)."""
        scheme, n, m = self._scheme, self._n, self._m
        box = out[: 4 * n].reshape(4, n)
        Jc = out[4 * n : 4 * n + m * n].reshape(m, n)
        if isinstance(scheme, QPScheme):
            relaxed, active, met, residual, _, defer = outcome
            if not defer:
                return scheme._finished(box, codes_, Jc, met, active, residual, relaxed,
                                        keep=False)  # fmt: skip
            result = scheme._step(self._robot, q, self._Jm, self._xd)
        else:
            method, s, relaxed, active, met, ill, full = outcome
            if ill:
                scheme._inputs(self._robot, q, Jc, self._xd)  # its workspace, for the LP
            result = scheme._finished(Jc, self._xd, box, codes_, Jc, method, s, relaxed, active,
                                      met, ill, full, keep=ill)  # fmt: skip
            if not ill:
                return result
        np.add(q, result.qd * self._dt, out=q_next)
        return result


def box_step(robot: Robot, scheme: Any, config: FloatArray) -> BoxStep | bool:
    """The one-call step for ``scheme`` on the controller's ``config``; False when it does
    not apply (not a plain :class:`~redres.resolution.SNSScheme` or
    :class:`~redres.resolution.QPScheme` with one level, no collisions and DAQP,
    objectives without a diagonal quadratic form, no chain in ``config``: ``CFG_JOINTS``
    0); True when it does but its kernels compile behind (the controller asks again at
    later steps)."""
    kind = type(scheme)
    if kind is QPScheme and (scheme.levels or scheme.collisions is not None
                             or scheme.solver != "daqp"):  # fmt: skip
        return False
    if kind not in (SNSScheme, QPScheme) or config[codes.CFG_JOINTS] == 0:
        return False
    quadratic = None
    if scheme.objectives:
        quadratic = quadratic_coefficients(robot, scheme.objectives)
        if quadratic is None:
            return False
    if not KERNELS.ready(_MODULE):
        return True
    return BoxStep(robot, scheme, config, quadratic)
