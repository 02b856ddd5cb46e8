"""What the hard-limit schemes share (internal): :class:`BoxScheme`, the kernels'
workspace, the step prologue, the diagnostics and the lazily built list of binding bounds.

A hard-limit step is one compiled call (:mod:`._kernels`): it checks the inputs, builds the
joint-velocity box of :mod:`.box`, resolves the task inside it and fills preallocated
rows — ``out`` (q̇, null-space term, lower, upper) and ``codes`` (bound kinds, relaxed).
Everything a caller may never read (the bindings as namedtuples, the singular values of
``J``) is computed on first access.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..._validate import FloatArray, as_scalar, real_array
from ...linalg import RCOND, InverseInfo
from ...linalg._engine import invert
from ..base import Scheme, StepResult
from ..gradient_projection import WeightedObjective, total_gradient, weighted_objectives
from ._codes import MET_ROUNDING, MET_TOLERANCE
from ._compiled import KERNELS, kernels
from .box import Binding, JointLimits, binding_bounds

if TYPE_CHECKING:
    from ..._toml import ScenarioParams
    from ...robot import Robot

#: Argument names for :func:`~redres.linalg._status.raise_status` other than its own.
STEP_NAMES = {"grad": "the secondary velocity (objective gradients)"}


class Workspace:
    """Arrays of one robot and task size, and the limits, for the kernels (internal)."""

    def __init__(self, limits: JointLimits, m: int) -> None:
        n = limits.n
        self.key: tuple[int, int] = (n, m)
        self.lim = np.ascontiguousarray(
            np.vstack([limits.q_min, limits.q_max, limits.qd_max, limits.qdd_max])
        )
        self.zero = np.zeros(n)
        self.M = np.zeros((3, m, m))
        self.wm = np.zeros((3, m))
        self.wn = np.zeros((6, n))
        self.wb = np.zeros((3, n), np.bool_)

    def outputs(self) -> tuple[FloatArray, NDArray[np.int8], FloatArray]:
        """Fresh per-step outputs: ``out`` (q̇, null term, lower, upper), ``codes`` (bound
        kinds, relaxed) and ``Jc`` (the kernel's copy of ``J``)."""
        n, m = self.key
        return np.empty((4, n)), np.empty((3, n), np.int8), np.empty((m, n))


class BindingList(Sequence[Binding]):
    """The :func:`~redres.resolution.hard_limits.binding_bounds` of a step, built on first
    access from the kernel's rows (a list of namedtuples costs microseconds a step; most
    loops never read it). Compares equal to a list with the same entries."""

    __slots__ = ("_codes", "_items", "_out")

    def __init__(self, out: FloatArray, codes: NDArray[np.int8]) -> None:
        self._out, self._codes = out, codes
        self._items: list[Binding] | None = None

    def _list(self) -> list[Binding]:
        if self._items is None:
            out, codes = self._out, self._codes
            self._items = binding_bounds(out[0], out[2], out[3], codes[0], codes[1], codes[2])
        return self._items

    def __getitem__(self, index: Any) -> Any:
        return self._list()[index]

    def __len__(self) -> int:
        return len(self._list())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Sequence) and self._list() == list(other)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return repr(self._list())


def step_info(J: FloatArray, method: str) -> InverseInfo:
    """Diagnostics of a hard-limit step: the singular values and rank of ``J`` from
    :mod:`redres.linalg`'s engine and its one rank rule (``σ > RCOND·σ_max``)."""
    stats = invert(J, weights=None, weights_name="W", damping=0.0, rcond=RCOND,
                   want_pinv=False, want_projector=False).stats  # fmt: skip
    rank = stats.rank
    return InverseInfo(rank, rank == min(J.shape), stats.sigma_min, stats.sigma_max, 0.0, method)


class BoxScheme(Scheme):
    """What the hard-limit schemes share: the control period, the limits' overrides, the
    secondary objectives and their gain, and the previous joint velocity
    :attr:`qd_prev` that the box is built from."""

    hard_limits = True

    def _init_box(
        self,
        dt: float,
        objectives: Sequence[WeightedObjective],
        k_null: float,
        qd_max: ArrayLike | None,
        qdd_max: ArrayLike | None,
    ) -> None:
        self.dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
        self.objectives = tuple(weighted_objectives(objectives))
        self.k_null = as_scalar(k_null, "k_null", minimum=0.0)
        # Checked for type here (complex or non-numbers refused by name); for shape and
        # values against the robot by JointLimits.from_robot on the first step.
        self._overrides = (
            None if qd_max is None else real_array(qd_max, "qd_max", "a number or a vector"),
            None if qdd_max is None else real_array(qdd_max, "qdd_max", "a number or a vector"),
        )
        #: The previous joint velocity (``None`` = at rest); the scheme's own copy.
        self.qd_prev: FloatArray | None = None
        self._robot: Any = None
        self._ws: Any = None
        #: Kernel modules the entry points were prepared on as plain Python (compiling
        #: behind, :mod:`redres._compile`); prepared again, compiled, once they are ready.
        self._pending: tuple[str, ...] = ()

    @classmethod
    def from_scenario(cls, params: ScenarioParams) -> Scheme:
        """The scheme of a scenario table: ``objectives`` and ``k_null``, planned over the
        run's own period ``dt`` (the limits are the robot's)."""
        build: Any = cls  # SNSScheme and QPScheme take dt, objectives and k_null
        return build(  # type: ignore[no-any-return]
            dt=params.dt, objectives=params.objectives(), k_null=params.nonnegative("k_null", 1.0)
        )

    def _reset(self) -> None:
        self.qd_prev = None

    def limits(self, robot: Robot) -> JointLimits:
        """The limits this scheme enforces on ``robot``."""
        return JointLimits.from_robot(robot, qd_max=self._overrides[0],
                                      qdd_max=self._overrides[1])  # fmt: skip

    def _prepare(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> None:
        """(Re)build the workspace and kernel entry points for ``robot`` and ``J``'s size."""
        raise NotImplementedError

    def _inputs(
        self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray
    ) -> tuple[Workspace, FloatArray, FloatArray]:
        """The step prologue: ``(workspace, qd0, qd_prev)``, the workspace rebuilt when the
        robot or the task size changes, ``qd0 = −k_null Σ wᵢ ∇Dᵢ`` the secondary velocity
        (zeros without objectives)."""
        if (
            robot is not self._robot
            or self._ws.key[1] != xd.shape[0]
            or (self._pending and all(map(KERNELS.ready, self._pending)))
        ):
            self._prepare(robot, q, J, xd)
        ws = self._ws
        qd0 = ws.zero
        if self.objectives:
            qd0 = (-self.k_null) * total_gradient(robot, q, self.objectives)  # new, C order
        prev = ws.zero if self.qd_prev is None else self.qd_prev
        return ws, qd0, prev

    def _result(
        self,
        out: FloatArray,
        codes: NDArray[np.int8],
        Jc: FloatArray,
        feasible: bool,
        active: int,
        details: Callable[[], Any],
        keep: bool = True,
    ) -> StepResult:
        """The step's result from the kernel's rows (``q̇`` also becomes :attr:`qd_prev`
        when ``keep``; the controller's one-call step keeps it itself); ``info``,
        ``null_term`` and ``details`` are built on first read."""
        qd = out[0]
        if keep:
            self.qd_prev = qd.copy()  # the scheme's own copy
        return StepResult.lazy(
            qd, lambda: step_info(Jc, self.name), lambda: null_term(Jc, qd, out[1]), feasible,
            BindingList(out, codes) if active else (), details,
        )  # fmt: skip


def null_term(J: FloatArray, qd: FloatArray, null: FloatArray) -> FloatArray:
    """A step's ``null_term``, ``(I − J⁺J) q̇`` (zeros where ``J`` is rank-deficient),
    written into ``null`` when first read (:func:`._kernels.null_term`)."""
    kernels().null_term(J, qd, null)
    return null


def task_met(J: FloatArray, xd: FloatArray, qd: FloatArray) -> bool:
    """Whether ``q̇`` meets the task (:data:`._codes.MET_TOLERANCE`; the kernels'
    ``_task_met``): the meaning of ``StepResult.feasible`` for SNS and QP alike, checked
    whenever the algorithm itself did not conclude so."""
    residual = float(np.linalg.norm(J @ qd - xd))
    size = float(np.linalg.norm(J)) * float(np.linalg.norm(qd))
    return residual <= MET_TOLERANCE * float(np.linalg.norm(xd)) + MET_ROUNDING * size


def box_details(
    out: FloatArray, codes: NDArray[np.int8], relaxed: int
) -> tuple[tuple[FloatArray, FloatArray], list[int]]:
    """The ``bounds`` and ``relaxed`` fields of a step's details: the box and the joints
    whose box had to give up a limit (``relaxed`` counts them)."""
    return (out[2], out[3]), np.flatnonzero(codes[2]).tolist() if relaxed else []
