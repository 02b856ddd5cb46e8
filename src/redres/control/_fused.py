"""The compiled paths' plumbing for :class:`~redres.control.Controller` (internal).

The fused kernels (``redres.control._kernels.clik_step`` and ``frame_command``, and their
serial-chain forms ``chain_step`` and ``chain_command``) read their settings and target
from one ``config`` vector laid out by the ``CFG_*`` offsets of ``redres.linalg._codes``
and write their results into one output block (:func:`block_size`). This module decides
which path a task and scheme allow (:func:`choose_path`) and whether the frame's
kinematics come from its serial chain (:func:`serial_chain`), builds that vector, picks
the kernels' entry points and turns their status codes into errors.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from .. import _compile
from .._validate import FloatArray
from ..errors import NonFiniteError, ShapeError
from ..linalg import InverseInfo
from ..linalg import _backend as be
from ..linalg import _codes as codes
from ..linalg._status import raise_status
from ..objectives import quadratic_coefficients
from ..resolution import GradientProjectionScheme, Inverse, PseudoInverseScheme, Scheme
from ..tasks import FrameTask, Task

if TYPE_CHECKING:
    from ..robot import Robot
    from ..robot.chain import SerialChain

Path = Literal["fused", "frame", "composed"]

_F64 = np.float64
#: The fused kernels (their callees in linalg and the serial-chain kernels are compiled
#: into them). Cold: a first controller 15-17 s in all, mostly its callees.
#: Their hard-limit form (redres.control._box_kernels) compiles the SNS kernels into it.
_BOX = "redres.control._box_kernels"
KERNELS = _compile.KernelGroup(
    "controller", ("redres.control._kernels", _BOX), cold_seconds=7.0, others={_BOX: 6.0}
)
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
    # front end evaluates it exactly. Nothing is compiled here: the controller compiles
    # the one entry point its path takes (the warm-up compiles them all).
    plain = isinstance(task, FrameTask) and type(task).compute is FrameTask.compute
    if not plain or not be.routed() or KERNELS.module() is None:
        return "composed", None
    fused = fusion(robot, scheme)
    if fused is None:
        return "frame", None
    return "fused", fused


#: The entry points a controller's path takes: (front end, fused step) by whether the
#: frame's kinematics come from its serial chain.
ENTRIES = {True: ("chain_command", "chain_step"), False: ("frame_command", "clik_step")}


def serial_chain(robot: Robot, frame: str | None) -> SerialChain | None:
    """``frame``'s serial chain (:meth:`redres.Robot.chain`), or None when the robot is not
    a serial chain up to it (then Pinocchio computes its kinematics)."""
    from ..robot.chain import NotSerialChainError

    try:
        return robot.chain(frame)
    except NotSerialChainError:
        return None


def block_size(n: int) -> int:
    """Length of the fused kernels' output block for ``n`` joints: ``qd`` (n), five
    diagnostics, ``e`` (6), the pose (16) and the Jacobian (6 n)
    (``redres.control._kernels.clik_step``; ``q+`` goes to an array of its own)."""
    return 7 * n + 27


def ready(entry: str) -> bool:
    """Whether kernel ``entry`` (of :data:`ENTRIES`) runs compiled (``KERNELS.ready`` of its
    part; False while it compiles behind). The chain kernels it calls are compiled
    into it (numba links a callee's code into its caller's, cached with it); the
    controller's own calls of a :class:`~redres.robot.SerialChain` switch when the chain's
    module is ready."""
    return KERNELS.ready(part=entry)


def fused_config(
    robot: Robot,
    rows: NDArray[np.int64],
    gain: float | FloatArray,
    dt: float,
    limit_velocity: bool,
    fused: Fusion | None,
    chain: SerialChain | None = None,
) -> FloatArray:
    """The kernels' ``config`` vector (layout: the ``CFG_*`` offsets) for a robot, the
    task ``rows`` and their validated ``gain`` (1/s, from
    :func:`redres._validate.as_gains`; other rows 0), on the fused path the scheme's
    settings (the summed costs' ``a, r``) and, for the chain kernels, the frame's serial
    ``chain`` (its arrays flattened: one argument for the kernel instead of four); the
    target starts as the identity pose at rest."""
    n = robot.n
    links, axes, kinds = chain.arrays if chain is not None else (np.zeros(0),) * 3
    v = codes.CFG_VECTORS
    config = np.zeros(v + 3 * n + len(rows))
    config[codes.CFG_ROTATION : codes.CFG_ROTATION + 9] = np.eye(3).ravel()
    config[codes.CFG_GAIN + rows] = gain
    config[codes.CFG_DT] = dt
    config[codes.CFG_LIMIT] = 1.0 if limit_velocity else 0.0
    config[codes.CFG_ROWS] = len(rows)
    config[codes.CFG_JOINTS] = len(kinds)
    config[v + 2 * n : v + 3 * n] = robot.qd_max
    config[v + 3 * n :] = rows
    if chain is not None:
        config = np.concatenate([config, links.ravel(), axes.ravel(), kinds])
    if fused is None:
        return config
    mode, lam, lam_max, eps = be.parse_damping(fused.inverse.damping)
    config[codes.CFG_K_NULL] = fused.k_null
    config[codes.CFG_DAMPING] = lam
    config[codes.CFG_MAX_DAMPING] = lam_max
    config[codes.CFG_THRESHOLD] = eps
    config[codes.CFG_MODE] = codes.LAZY if mode == codes.FIXED else mode  # Controller.info
    config[codes.CFG_RCOND] = fused.inverse.rcond
    if fused.quadratic is not None:
        config[codes.CFG_HAS_GRAD] = 1.0
        config[v : v + n], config[v + n : v + 2 * n] = fused.quadratic
    return config


def native(name: str) -> Callable[..., Any] | None:
    """The native entry point of kernel ``name`` (``clik_step``, ``chain_step``,
    ``frame_command``, ``chain_command`` or ``integrate`` of
    :mod:`redres.control._kernels`), or None without compiled kernels.

    Its arguments must have the types of the kernel's docstring, as float64 C-contiguous
    arrays: a mismatched type is not detected by the entry point, so callers check their
    arrays once.
    """
    # One joint, one task row; the chain kernels' config holds a one-joint chain
    # (links 2 x 12, axis 3, kind 1).
    config = np.zeros(codes.CFG_VECTORS + 3 + 1)
    config[codes.CFG_ROWS] = 1.0
    chain = np.concatenate([config, np.zeros(12 * 2 + 3 + 1)])
    chain[codes.CFG_JOINTS] = 1.0
    frame = (np.zeros((6, 1)), np.eye(4), np.zeros(1), config)
    task = (np.zeros((1, 1)), np.zeros(1))
    warm = {
        "clik_step": (*frame, np.zeros(1), np.zeros(block_size(1))),
        "chain_step": (chain, np.zeros(1), np.zeros(1), np.zeros(block_size(1))),
        "frame_command": (*frame, *task, np.zeros(6)),
        "chain_command": (chain, np.zeros(1), np.zeros(22 + 6), *task),
        "integrate": (np.zeros(1), np.zeros(1), 0.0, np.zeros(1)),
    }
    return be.entry(KERNELS, name, warm[name])


def kernel_for(robot: Robot, frame_id: int, name: str) -> Any:
    """Kernel ``name``'s :func:`native` entry point when the arrays Pinocchio returns have
    the layout it was compiled for (float64, C order), numba's dispatcher if not, None
    without compiled kernels (a chain kernel's entry point as it is)."""
    entry = native(name)
    if entry is None or name.startswith("chain"):
        return entry
    placement, J = robot.placement_jacobian(robot.neutral(), frame_id)
    H = placement.homogeneous
    if all(x.dtype == _F64 and x.flags.c_contiguous for x in (J, H)):
        return entry
    kernels = KERNELS.module()  # pragma: no cover - a Pinocchio build with other layouts
    return None if kernels is None else getattr(kernels, name)  # pragma: no cover


_LABELS = ("pinv", "damped", "adaptive", "selective", "damped")  # by mode (LAZY last)
_new_info = tuple.__new__


def fused_info(out: FloatArray, n: int, rows: NDArray[np.int64], config: FloatArray) -> InverseInfo:
    """The :class:`~redres.linalg.InverseInfo` of a fused step from its output block
    ``out`` (:func:`block_size`): rank, σ_min, σ_max and damping as the kernel wrote them,
    or, where fixed damping skipped them (rank -1), the singular values of the task
    ``rows`` of its Jacobian."""
    m = rows.shape[0]
    rank, smin, smax, used = out[n : n + 4].tolist()
    rank = int(rank)
    if rank < 0:
        J = out[n + 27 :].reshape(6, n)[rows]
        sigma = np.linalg.svd(J, compute_uv=False)
        smax = float(sigma[0])
        smin = float(sigma[-1]) if m <= n else 0.0
        rank = int(np.count_nonzero(sigma > config[codes.CFG_RCOND] * smax))
    label = _LABELS[int(config[codes.CFG_MODE])]
    return _new_info(InverseInfo, (rank, rank == min(m, n), smin, smax, used, label))  # type: ignore[no-any-return]


def raise_for_status(status: int, n: int) -> None:
    """Raise the error a fused kernel's status code stands for."""
    if status == codes.Q_NONFINITE:
        raise NonFiniteError("q contains NaN or infinity")
    if status == codes.Q_SHAPE:
        raise ShapeError(f"q must have shape ({n},)")
    if status == codes.POSE_NONFINITE:
        raise NonFiniteError("the frame placement is not finite (is q astronomically large?)")
    raise_status(status, {"J": "the frame Jacobian", "xd": "the task command"})


def adopt_target(
    task: Task,
    block: FloatArray,
    q: FloatArray,
    robot: Robot,
    fid: int,
    chain: SerialChain | None,
) -> None:
    """Make a compiled path's settings ``block`` hold the frame task's target (at the
    first step, or after another controller stepped the same task); without a target, the
    pose of frame ``fid`` at ``q`` becomes it (hold still), computed as the step does."""
    assert isinstance(task, FrameTask)  # the compiled paths are a frame task's
    n = robot.n
    if q.shape != (n,):
        raise ShapeError(f"q must have shape ({n},); got {q.shape}")
    if not task._has_target:
        if not np.all(np.isfinite(q)):
            raise NonFiniteError("q contains NaN or infinity")
        if chain is None:
            H = robot.placement_jacobian(q, fid)[0].homogeneous
        else:
            H = chain.fk(q)
        task.set_target(H, validate=False)
    task._share_target(block)  # set_target writes the kernel's slots from now on
