"""The controller's one-call step for the hard-limit schemes (internal).

On a plain frame task whose frame ends a serial chain, a plain
:class:`~redres.resolution.SNSScheme` or :class:`~redres.resolution.QPScheme` (one level,
no collision rows, DAQP as its backend) whose objectives are diagonal quadratics
(joint-limit mid-range, posture) or none runs front end, box, resolution and integration
in one compiled call (:mod:`redres.control._box_kernels`) instead of the front end's call,
then the scheme's ``_step`` in Python. SNS runs the same kernels on the same numbers, so
the two give the same bits; the QP's two problems are solved by the compiled solvers of
:mod:`redres.resolution.hard_limits._dense_qp_kernels` instead of DAQP (the same optimum to
rounding), and where one of them breaks down or the answer needs the scheme's refinement,
the scheme's own step takes over on the kernel's task rows. The scheme stays the owner of
its state (``qd_prev``, the QP's last verdict) and of the step's result (``_finished``).
:func:`box_step` says whether a controller can take it.
"""

from __future__ import annotations

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
        self._zero = np.zeros(n)
        self._shape = (3, n)
        name = "chain_qp_step" if qp else "chain_sns_step"
        entry = KERNELS.entry(name, self._arguments(self._zero, np.empty(n)), _MODULE)
        assert entry is not None  # numba imports: box_step found the kernels
        self._entry: Any = entry
        self._infeasible = kernels.INFEASIBLE  # the scheme's verdict, set at each step

    def _arguments(
        self, q: FloatArray, q_next: FloatArray, prev: FloatArray | None = None
    ) -> tuple[Any, ...]:
        """The kernel's arguments for a step at ``q`` (and a new ``out``, ``codes``)."""
        return (self._config, q, self._zero if prev is None else prev, q_next, self._state,
                _empty(self._out_size), _empty(self._shape, _int8), self._flags)  # fmt: skip

    def __call__(self, q: FloatArray) -> tuple[FloatArray, StepResult, FloatArray, FloatArray]:
        """The step at ``q`` (float64, C order): ``(q⁺, the scheme's result, the frame's
        error (6,), its pose (4, 4))``; ``q̇`` becomes the scheme's ``qd_prev``."""
        scheme, n, m = self._scheme, self._n, self._m
        q_next = _empty(n)
        if self._qp:  # the scheme's last verdict (its own state: a reset clears it)
            self._state[self._infeasible] = scheme._infeasible_before  # type: ignore[union-attr]
        args = self._arguments(q, q_next, scheme.qd_prev)
        status, *outcome = self._entry(*args)
        if status:
            raise_for_status(status, n)
        out, codes_ = args[5], args[6]
        box = out[: 4 * n].reshape(4, n)
        Jc = out[4 * n : 4 * n + m * n].reshape(m, n)
        tail = 4 * n + m * n
        error, pose = out[tail : tail + 6], out[tail + 6 : tail + 22].reshape(4, 4)
        if self._qp:
            return (*self._qp_result(q, q_next, box, codes_, Jc, *outcome), error, pose)
        ill = outcome[5]
        if ill:  # the scheme's path may change q̇ (the LP on orthonormal rows)
            scheme._inputs(self._robot, q, Jc, self._xd)  # its workspace, for the LP
        result = scheme._finished(Jc, self._xd, box, codes_, Jc, *outcome)  # type: ignore[union-attr]
        if ill:
            np.add(q, box[0] * self._dt, out=q_next)
        return q_next, result, error, pose

    def _qp_result(
        self, q: FloatArray, q_next: FloatArray, box: FloatArray, codes_: Any, Jc: FloatArray,
        relaxed: int, active: int, met: bool, residual: float, infeasible: bool, defer: bool,
    ) -> tuple[FloatArray, StepResult]:  # fmt: skip
        """``(q⁺, result)`` of a QP step from the kernel's outcome; where it defers, the
        scheme's own step on the kernel's task rows (DAQP, the refinement)."""
        scheme = self._scheme
        assert isinstance(scheme, QPScheme)
        if defer:
            result = scheme._step(self._robot, q, self._Jm, self._xd)
            np.add(q, result.qd * self._dt, out=q_next)
            return q_next, result
        scheme._infeasible_before = infeasible
        return q_next, scheme._finished(box, codes_, Jc, met, active, residual, relaxed)


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
