"""Compiled rigid-body dynamics of a serial chain: pose, Jacobian, ``J̇ q̇``, ``M`` and
``b`` of one frame in one call, and the operational-space torque step built on them
(kernels in :mod:`redres.dynamics._kernels`, whose docstring gives the algorithms).

They equal Pinocchio's ``crba``, ``nonLinearEffects`` and the frame's world-aligned
Jacobian and its time variation (``tests/dynamics/test_chain_dynamics.py``: 1e-12 on every
built-in arm, file robots and payloads), without a Pinocchio call or a write into
``robot.data``. Covered: a model whose joints are all one-DOF revolute or prismatic joints
in one serial chain from the base to the frame (:class:`redres.robot.SerialChain`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

import numpy as np

from .. import _compile
from .._validate import FloatArray, as_vector
from ..robot.chain import NotSerialChainError
from ._codes import OUT_ERROR, OUT_POSE, OUT_STATS, OUT_TARGET
from .base import ControlStep

if TYPE_CHECKING:
    from ..linalg import InverseInfo
    from ..robot import Robot

__all__ = ["ChainDynamics", "ChainTerms", "KernelControlStep", "StepOutput"]

#: The compiled torque step. Cold: a first operational-space step 19.4 s in all with the
#: linalg and chain kernels it calls (empty cache, load 0.7); warm 0.7 s.
#: ``_consistent_kernels``: the QR of the operational-space torques, compiled into the step.
KERNELS = _compile.KernelGroup(
    "dynamics",
    ("redres.dynamics._kernels", "redres.dynamics._consistent_kernels"),
    cold_seconds=10.0,
)


class ChainTerms(NamedTuple):
    """The dynamic terms of one frame at ``(q, q̇)``.

    Attributes:
        pose: the frame's pose, ``(4, 4)``.
        jacobian: its world-aligned geometric Jacobian, ``(6, n)``, rows ``[v; ω]``.
        jdot_qd: ``J̇ q̇``, ``(6,)`` (m/s², rad/s²): the frame origin's classical acceleration
            at ``q̈ = 0``.
        mass_matrix: ``M(q)`` with the armature, ``(n, n)``.
        bias: ``C(q, q̇) q̇ + g(q)``, ``(n,)``, N·m.
    """

    pose: FloatArray
    jacobian: FloatArray
    jdot_qd: FloatArray
    mass_matrix: FloatArray
    bias: FloatArray


class ChainDynamics:
    """The arrays of the compiled dynamics of ``robot`` for ``frame`` (default: its tip),
    read once from its Pinocchio model (later changes to the model are not seen: build
    another for a robot with a payload).

    Raises:
        NotSerialChainError: a joint is not on the chain from the base to the frame, or is
            not a one-DOF revolute or prismatic joint.
    """

    def __init__(self, robot: Robot, frame: str | None = None) -> None:
        """The arguments are described in ``help(ChainDynamics)``."""
        chain = robot.chain(frame)
        model = robot.model
        ids = [int(model.getJointId(name)) for name in chain.joints]
        if ids != list(range(1, robot.n + 1)) or model.nq != robot.n:
            raise NotSerialChainError(
                f"the compiled dynamics need every joint on the chain to {chain.frame!r}; "
                f"it holds {len(ids)} of the model's {robot.n} joints"
            )
        self.n = robot.n
        self.frame = chain.frame
        inertias = [model.inertias[j] for j in ids]
        self.body = np.array([[I.mass, *I.lever, *I.inertia[0], *I.inertia[1, 1:], I.inertia[2, 2]]
                              for I in inertias])  # fmt: skip
        self.armature = np.ascontiguousarray(model.armature, dtype=float)
        self.gravity = np.array(model.gravity.linear, dtype=float)
        self.damping = np.ascontiguousarray(robot.joint_damping, dtype=float)
        self.arrays = (*chain.arrays, self.body, self.armature, self.gravity)
        self._chain = chain

    def pose(self, q: FloatArray) -> FloatArray:
        """The frame's pose (4x4) at a validated ``q`` (the serial chain's kernel)."""
        return self._chain.fk(q)

    def terms(self, q: Any, qd: Any) -> ChainTerms:
        """:class:`ChainTerms` at ``(q, q̇)`` in one compiled call.

        Raises:
            ShapeError, NonFiniteError: ``q`` or ``qd`` of the wrong shape or not finite.
        """
        qv, qdv = as_vector(q, "q", self.n), as_vector(qd, "qd", self.n)
        n = self.n
        out = ChainTerms(np.empty((4, 4)), np.empty((6, n)), np.empty(6), np.empty((n, n)),
                         np.empty(n))  # fmt: skip
        kernels = KERNELS.required(
            "compiled dynamics", otherwise="use Robot.mass_matrix and Robot.bias"
        )
        kernels.chain_dynamics(*self.arrays, qv, qdv, *out)  # q, qd checked finite above
        return out


def chain_dynamics(robot: Robot, frame: str | None = None) -> ChainDynamics | None:
    """``robot``'s :class:`ChainDynamics` for ``frame``, or None when the model is not one
    serial chain up to it (the callers' Pinocchio path answers)."""
    try:
        return ChainDynamics(robot, frame)
    except NotSerialChainError:
        return None


class StepOutput(Protocol):
    """What a :class:`KernelControlStep` reads its output with: the joints, and the
    inverse's diagnostics in one output array (the compiled step that wrote it)."""

    n: int

    def info(self, out: FloatArray) -> InverseInfo:
        """The inverse's diagnostics in ``out``."""
        ...


class KernelControlStep(ControlStep):
    """The :class:`~redres.dynamics.ControlStep` of the compiled operational-space step,
    read from the kernel's output (one array, the layout of :mod:`redres.dynamics._codes`)
    when a field is read: nothing is built before. Immutable, as every ``ControlStep``.

    Args:
        out: the output of one step (the step's own copy), ``(4 n + …,)``.
        source: the compiled step that wrote it (its joints ``n``, its ``info(out)``).
    """

    def __init__(self, out: FloatArray, source: StepOutput) -> None:
        """The arguments are described in ``help(KernelControlStep)``."""
        fields = self.__dict__  # frozen: set once, without the dataclass' checks
        fields["_out"], fields["_source"] = out, source

    @property
    def tau(self) -> FloatArray:  # type: ignore[override]
        """Commanded joint torques, ``(n,)``, N·m."""
        fields = self.__dict__
        return fields["_out"][: fields["_source"].n]  # type: ignore[no-any-return]

    @property
    def info(self) -> InverseInfo:  # type: ignore[override]
        """Diagnostics of ``J̄`` (singular values of ``J M^{-1/2}``), built on first read."""
        fields = self.__dict__
        found = fields.get("_info")
        if found is None:
            found = fields["_info"] = fields["_source"].info(fields["_out"])
        return found  # type: ignore[no-any-return]

    def _part(self, start: int, stop: int) -> FloatArray:
        out, n = self.__dict__["_out"], self.__dict__["_source"].n
        return out[4 * n + start : 4 * n + stop]  # type: ignore[no-any-return]

    @property
    def error(self) -> FloatArray:  # type: ignore[override]
        """Six-row task error ``[p_d − p; log(R_d Rᵀ)]``, ``(6,)``, m and rad."""
        return self._part(OUT_ERROR, OUT_POSE)

    @property
    def pose(self) -> FloatArray:  # type: ignore[override]
        """Pose of the task frame, 4x4."""
        return self._part(OUT_POSE, OUT_TARGET).reshape(4, 4)

    @property
    def target(self) -> FloatArray:  # type: ignore[override]
        """Target pose, 4x4."""
        return self._part(OUT_TARGET, OUT_STATS).reshape(4, 4)

    @property
    def tau_null(self) -> FloatArray:  # type: ignore[override]
        """Null-space part ``(I − Jᵀ J̄ᵀ) τ₀`` of ``tau``, ``(n,)``, N·m."""
        n = self.__dict__["_source"].n
        return self.__dict__["_out"][2 * n : 3 * n]  # type: ignore[no-any-return]

    @property
    def extra(self) -> dict[str, Any]:  # type: ignore[override]
        """``{"tau0": τ₀}``, the null-space torque before projection, ``(n,)``, N·m."""
        n = self.__dict__["_source"].n
        return {"tau0": self.__dict__["_out"][3 * n : 4 * n]}
