"""The compiled step's plumbing for :class:`~redres.control.ClikController` (internal).

The fused kernels (``redres.linalg._kernels.clik_step`` and ``frame_command``) read their
settings and target from one ``config`` vector laid out by the ``CFG_*`` offsets of
``redres.linalg._codes``; this module builds it, picks the kernels' entry points and turns
their status codes into errors.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_scalar, as_vector
from ..errors import InvalidParameterError, NonFiniteError, ShapeError
from ..linalg import _backend as be
from ..linalg import _codes as codes
from ..objectives import Objective

if TYPE_CHECKING:
    from ..robot import Robot

_F64 = np.float64


def fused_config(
    robot: Robot,
    gains: FloatArray,
    k_null: float,
    rate_kwargs: dict[str, Any],
    dt: float,
    limit_velocity: bool,
    quadratic: tuple[FloatArray, FloatArray] | None,
) -> tuple[FloatArray, int]:
    """``(config, damping mode)``: the kernel's settings for a robot, the six per-row
    ``gains``, the inverse's ``rate_kwargs`` (:meth:`InverseChoice.rate_kwargs`) and the
    secondary gradient ``a ∘ q − b`` (``quadratic = (a, b)``, None for none); the target
    starts as the identity pose at rest."""
    n = robot.n
    mode, lam, lam_max, eps = be.parse_damping(rate_kwargs["damping"])
    config = np.zeros(codes.CFG_VECTORS + 3 * n)
    config[codes.CFG_ROTATION : codes.CFG_ROTATION + 9] = np.eye(3).ravel()
    config[codes.CFG_GAIN : codes.CFG_GAIN + 6] = gains
    config[codes.CFG_K_NULL] = k_null
    config[codes.CFG_DAMPING] = lam
    config[codes.CFG_MAX_DAMPING] = lam_max
    config[codes.CFG_THRESHOLD] = eps
    config[codes.CFG_MODE] = mode
    config[codes.CFG_DT] = dt
    config[codes.CFG_RCOND] = rate_kwargs.get("rcond", 1e-10)
    config[codes.CFG_LIMIT] = 1.0 if limit_velocity else 0.0
    v = codes.CFG_VECTORS
    if quadratic is not None:
        config[codes.CFG_HAS_GRAD] = 1.0
        config[v : v + n], config[v + n : v + 2 * n] = quadratic
    config[v + 2 * n : v + 3 * n] = robot.qd_max
    return config, mode


def quadratic_coefficients(
    robot: Robot, objectives: Sequence[tuple[Objective, float]]
) -> tuple[FloatArray, FloatArray]:
    """``(a, b)`` with ``Σ wᵢ ∇Dᵢ(q) = a ∘ q − b`` for weighted diagonal quadratic costs."""
    a, b = np.zeros(robot.n), np.zeros(robot.n)
    for obj, weight in objectives:
        form = obj.quadratic_form(robot)
        if form is None:
            raise InvalidParameterError(
                f"ClikController fuses only diagonal quadratic costs (joint limits, "
                f"posture); {obj.name!r} is not one: use redres.control.run with a "
                f"GradientProjectionScheme for it"
            )
        ai, ri = (as_vector(x, f"quadratic form of {obj.name}", robot.n) for x in form)
        a += weight * ai
        b += weight * ai * ri
    return a, b


def row_gains(gain: Any, rows: list[int]) -> FloatArray:
    """Six per-row gains (unused rows 0) from a scalar or one value per task row."""
    g = np.asarray(gain, dtype=float) if not isinstance(gain, (int, float)) else None
    full = np.zeros(6)
    if g is None or g.ndim == 0:
        full[rows] = as_scalar(gain, "gain", minimum=0.0)
        return full
    values = as_vector(g, "gain", len(rows))
    if np.any(values < 0.0):
        raise InvalidParameterError(f"gain must be >= 0 on every row; got {values}")
    full[rows] = values
    return full


def kernel_for(robot: Robot, frame_id: int, entry_point: Any, name: str) -> Any:
    """A fused kernel's native entry point (from ``entry_point()``) when the arrays
    Pinocchio returns have the layout it was compiled for (float64, C order), numba's
    dispatcher ``name`` if not, None without compiled kernels."""
    entry = entry_point()
    if entry is None:
        return None
    placement, J = robot.placement_jacobian(robot.neutral(), frame_id)
    H = placement.homogeneous
    if all(x.dtype == _F64 and x.flags.c_contiguous for x in (J, H)):
        return entry
    kernels = be.kernels()  # pragma: no cover - a Pinocchio build returning other layouts
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
