"""The controller's one-call step for the hard-limit schemes (internal).

On a plain frame task whose frame ends a serial chain, a plain
:class:`~redres.resolution.SNSScheme` whose objectives are diagonal quadratics (joint-limit
mid-range, posture) or none runs front end, box, saturation in the null space and
integration in one compiled call (:func:`redres.control._box_kernels.chain_sns_step`)
instead of the front end's call, then the scheme's ``_step`` in Python: the same kernels
on the same numbers, so the two give the same bits. The scheme stays the owner of its
state (``qd_prev``) and of the step's result (``SNSScheme._finished``).
:func:`box_step` says whether a controller can take it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray
from ..linalg import _codes as codes
from ..objectives import quadratic_coefficients
from ..resolution import SNSScheme, StepResult
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
        scheme: SNSScheme,
        config: FloatArray,
        quadratic: tuple[FloatArray, FloatArray] | None,
    ) -> None:
        n, m = robot.n, int(config[codes.CFG_ROWS])
        kernels = KERNELS.module(_MODULE)
        assert kernels is not None  # box_step found them
        self._robot, self._scheme, self._config = robot, scheme, config
        self._n, self._m, self._dt = n, m, scheme.dt
        if quadratic is not None:
            v = codes.CFG_VECTORS
            config[codes.CFG_K_NULL] = scheme.k_null
            config[codes.CFG_HAS_GRAD] = 1.0
            config[v : v + n], config[v + n : v + 2 * n] = quadratic
        self._state = state = np.zeros(kernels.state_size(n, m, 0, 0))
        self._out_size = kernels.out_size(n, m)
        limits = scheme.limits(robot)
        head = kernels.HEADER
        state[kernels.TOLERANCE] = scheme.tolerance
        state[head : head + 4 * n] = np.concatenate(
            [limits.q_min, limits.q_max, limits.qd_max, limits.qdd_max]
        )
        rows = state[kernels._rows_end(n, m) - m * n - m : kernels._rows_end(n, m)]
        self._Jm, self._xd = rows[: m * n].reshape(m, n), rows[m * n :]
        self._flags = np.zeros((3, n), np.bool_)
        self._zero = np.zeros(n)
        self._shape = (3, n)
        entry = KERNELS.entry("chain_sns_step", self._arguments(self._zero, np.empty(n)), _MODULE)
        assert entry is not None  # numba imports: box_step found the kernels
        self._entry: Any = entry

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
        args = self._arguments(q, q_next, scheme.qd_prev)
        status, *outcome = self._entry(*args)
        if status:
            raise_for_status(status, n)
        out, codes_ = args[5], args[6]
        box = out[: 4 * n].reshape(4, n)
        Jc = out[4 * n : 4 * n + m * n].reshape(m, n)
        tail = 4 * n + m * n
        ill = outcome[5]
        if ill:  # the scheme's path may change q̇ (the LP on orthonormal rows)
            scheme._inputs(self._robot, q, Jc, self._xd)  # its workspace, for the LP
        result = scheme._finished(Jc, self._xd, box, codes_, Jc, *outcome)
        if ill:
            np.add(q, box[0] * self._dt, out=q_next)
        return q_next, result, out[tail : tail + 6], out[tail + 6 : tail + 22].reshape(4, 4)


def box_step(robot: Robot, scheme: Any, config: FloatArray) -> BoxStep | bool:
    """The one-call step for ``scheme`` on the controller's ``config``; False when it does
    not apply (not a plain :class:`~redres.resolution.SNSScheme`, objectives without a
    diagonal quadratic form, no chain in ``config``: ``CFG_JOINTS`` 0); True when it does
    but its kernels compile behind (the controller asks again at later steps)."""
    if type(scheme) is not SNSScheme or config[codes.CFG_JOINTS] == 0:
        return False
    quadratic = None
    if scheme.objectives:
        quadratic = quadratic_coefficients(robot, scheme.objectives)
        if quadratic is None:
            return False
    if not KERNELS.ready(_MODULE):
        return True
    return BoxStep(robot, scheme, config, quadratic)
