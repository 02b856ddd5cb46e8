"""The compiled paths' plumbing for :class:`~redres.control.Controller` (internal).

The fused kernels (``redres.control._kernels.clik_step`` and ``frame_command``) read their
settings and target from one ``config`` vector laid out by the ``CFG_*`` offsets of
``redres.linalg._codes``. This module decides which path a task and scheme allow
(:func:`choose_path`), builds that vector, picks the kernels' entry points and turns their
status codes into errors.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from .. import _jit
from .._validate import FloatArray, as_scalar, as_vector
from ..errors import InvalidParameterError, NonFiniteError, ShapeError
from ..linalg import _backend as be
from ..linalg import _codes as codes
from ..objectives import Objective
from ..resolution import GradientProjectionScheme, Inverse, PseudoInverseScheme, Scheme
from ..tasks import FrameTask, Task

if TYPE_CHECKING:
    from ..robot import Robot

Path = Literal["fused", "frame", "composed"]

_F64 = np.float64
_KERNELS = "redres.control._kernels"
#: The slots of the kernels' config vector holding the target: the rotation row-major,
#: the position, the twist (CFG_ROTATION, CFG_POSITION, CFG_TWIST = 0, 9, 12), the layout in
#: which a FrameTask keeps its target (FrameTask._share_target).
TARGET = slice(codes.CFG_ROTATION, codes.CFG_TWIST + 6)


class Fusion(NamedTuple):
    """What the fused kernel needs of a scheme: its inverse, the null-space gain and the
    summed quadratic costs ``Σ wᵢ ∇Dᵢ = a ∘ (q − r)`` as ``(a, r)`` (None: none)."""

    inverse: Inverse
    k_null: float
    quadratic: tuple[FloatArray, FloatArray] | None


def fusion(robot: Robot, scheme: Scheme) -> Fusion | None:
    """The fused kernel's settings for ``scheme``, or None when the kernel does not do
    what the scheme's ``_step`` does: a :class:`PseudoInverseScheme` or a
    :class:`GradientProjectionScheme` (not a subclass with its own ``_step``) whose
    objectives all declare a diagonal quadratic form."""
    step = type(scheme)._step
    if step is PseudoInverseScheme._step:
        return Fusion(scheme.inverse, 0.0, None)  # type: ignore[attr-defined]
    if step is not GradientProjectionScheme._step:
        return None
    quadratic = quadratic_coefficients(robot, scheme.objectives)
    if quadratic is None:
        return None
    return Fusion(scheme.inverse, scheme.k_null, quadratic)  # type: ignore[attr-defined]


def choose_path(robot: Robot, task: Task, scheme: Scheme) -> tuple[Path, Fusion | None]:
    """The controller's path (:mod:`redres.control.controller` describes the three), with
    the fused settings on the fused path."""
    # A FrameTask computed by FrameTask's own compute (it or a row subclass): the compiled
    # front end evaluates it exactly.
    plain = isinstance(task, FrameTask) and type(task).compute is FrameTask.compute
    if not plain or native("frame_command") is None:
        return "composed", None
    fused = fusion(robot, scheme)
    if fused is None or native("clik_step") is None:
        return "frame", None
    return "fused", fused


def fused_config(
    robot: Robot,
    rows: NDArray[np.int64],
    gain: float | FloatArray,
    dt: float,
    limit_velocity: bool,
    fused: Fusion | None,
) -> FloatArray:
    """The kernels' ``config`` vector for a robot, the task ``rows`` and their validated
    ``gain`` (1/s, from :func:`task_gains`; other rows 0) and, on the fused path, the
    scheme's settings (the summed costs' ``a, r`` from CFG_VECTORS on); the target starts
    as the identity pose at rest."""
    n = robot.n
    config = np.zeros(codes.CFG_VECTORS + 3 * n)
    config[codes.CFG_ROTATION : codes.CFG_ROTATION + 9] = np.eye(3).ravel()
    config[codes.CFG_GAIN + rows] = gain
    config[codes.CFG_DT] = dt
    config[codes.CFG_LIMIT] = 1.0 if limit_velocity else 0.0
    v = codes.CFG_VECTORS
    config[v + 2 * n : v + 3 * n] = robot.qd_max
    if fused is None:
        return config
    mode, lam, lam_max, eps = be.parse_damping(fused.inverse.damping)
    config[codes.CFG_K_NULL] = fused.k_null
    config[codes.CFG_DAMPING] = lam
    config[codes.CFG_MAX_DAMPING] = lam_max
    config[codes.CFG_THRESHOLD] = eps
    config[codes.CFG_MODE] = mode
    config[codes.CFG_RCOND] = fused.inverse.rcond
    if fused.quadratic is not None:
        config[codes.CFG_HAS_GRAD] = 1.0
        config[v : v + n], config[v + n : v + 2 * n] = fused.quadratic
    return config


def quadratic_coefficients(
    robot: Robot, objectives: Sequence[tuple[Objective, float]]
) -> tuple[FloatArray, FloatArray] | None:
    """``(a, r)`` with ``Σ wᵢ ∇Dᵢ(q) = a ∘ (q − r)`` for weighted diagonal quadratic costs
    ``∇Dᵢ = aᵢ ∘ (q − rᵢ)``: ``a = Σ wᵢ aᵢ``, ``r = Σ wᵢ aᵢ rᵢ / a`` (0 where ``a = 0``;
    one cost's ``rᵢ`` as it is). None if a cost has no quadratic form (or there are none).
    """
    if not objectives:
        return None
    forms = []
    for obj, weight in objectives:
        form = obj.quadratic_form(robot)
        if form is None:
            return None
        ai, ri = (as_vector(x, f"quadratic form of {obj.name}", robot.n) for x in form)
        forms.append((weight * ai, ri))
    if len(forms) == 1:
        return forms[0]
    a = np.sum([ai for ai, _ in forms], axis=0)
    ar = np.sum([ai * ri for ai, ri in forms], axis=0)
    r = np.divide(ar, a, out=np.zeros(robot.n), where=a != 0.0)
    return a, r


def task_gains(gain: Any, m: int, name: str = "gain") -> float | FloatArray:
    """A task gain as a float, or one value per task row ``(m,)``, each ≥ 0 (1/s or 1/s²);
    errors name it ``name``."""
    if isinstance(gain, (int, float)) or np.ndim(gain) == 0:
        return as_scalar(gain, name, minimum=0.0)
    values = as_vector(gain, name, m).copy()
    if np.any(values < 0.0):
        raise InvalidParameterError(f"{name} must be >= 0 on every row; got {values}")
    return values


def native(name: str) -> Callable[..., Any] | None:
    """The native entry point of kernel ``name`` (``clik_step``, ``frame_command`` or
    ``integrate`` of :mod:`redres.control._kernels`), or None without compiled kernels.

    Its arguments must have the types of the kernel's docstring, as float64 (``rows``
    int64) C-contiguous arrays: a mismatched type is not detected by the entry point, so
    callers check their arrays once.
    """
    frame = (np.zeros((6, 1)), np.eye(4), np.zeros(1), np.arange(1, dtype=np.int64),
             np.zeros(codes.CFG_VECTORS + 3))  # fmt: skip
    warm = {
        "clik_step": (*frame, np.zeros(2 + 6)),
        "frame_command": (*frame, np.zeros((1, 1)), np.zeros(1), np.zeros(6)),
        "integrate": (np.zeros(1), np.zeros(1), 0.0, np.zeros(1)),
    }
    return be.entry(_KERNELS, name, warm[name])


def kernel_for(robot: Robot, frame_id: int, name: str) -> Any:
    """Kernel ``name``'s :func:`native` entry point when the arrays Pinocchio returns have
    the layout it was compiled for (float64, C order), numba's dispatcher if not, None
    without compiled kernels."""
    entry = native(name)
    if entry is None:
        return None
    placement, J = robot.placement_jacobian(robot.neutral(), frame_id)
    H = placement.homogeneous
    if all(x.dtype == _F64 and x.flags.c_contiguous for x in (J, H)):
        return entry
    kernels = _jit.load(_KERNELS)  # pragma: no cover - a Pinocchio build with other layouts
    return None if kernels is None else getattr(kernels, name)  # pragma: no cover


def raise_for_status(status: int, n: int) -> None:
    """Raise the error a fused kernel's status code stands for."""
    if status == codes.Q_NONFINITE:
        raise NonFiniteError("q contains NaN or infinity")
    if status == codes.Q_SHAPE:
        raise ShapeError(f"q must have shape ({n},)")
    if status == codes.POSE_NONFINITE:
        raise NonFiniteError("the frame placement is not finite (is q astronomically large?)")
    be.raise_status(status, {"J": "the frame Jacobian", "xd": "the task command"})
