"""Compiled kinematics of a serial chain, extracted once from a Pinocchio model.

:class:`SerialChain` reads, for the joints from the base to one frame, each joint's
placement in its parent joint (``model.jointPlacements``), its axis and kind, and the
frame's fixed placement in its joint, and computes that frame's pose, its geometric
Jacobian (world-aligned and local) and a frame task's pose error in compiled kernels
(:mod:`redres.robot._chain_kernels`, where the formulas are derived) without calling
Pinocchio. Pinocchio stays the reference (``tests/robot/test_chain.py`` checks every
model against it to 1e-12) and the path for everything else: a model that is not a
serial chain up to the frame is refused with :class:`NotSerialChainError`.

Accepted joints: revolute about a coordinate axis (``RX``, ``RY``, ``RZ``) or any axis
(``RevoluteUnaligned``), their unbounded (continuous) twins, and prismatic joints
(``PX``, ``PY``, ``PZ``, ``PrismaticUnaligned``). The chain's configuration is the
tangent one (``model.nv`` values): an unbounded revolute joint takes its angle, where
Pinocchio's configuration holds ``(cos, sin)``. A :class:`~redres.robot.Robot` has
none of those (``Robot.from_urdf`` bounds continuous joints), so there ``q`` is the
robot's ``q``.

The public methods validate their input; hot loops call the kernels themselves with
:attr:`SerialChain.arrays` as their leading arguments (the signatures are documented on
:func:`kernel`), so a batch kernel can run the same per-item kernel over a leading axis.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from .. import _compile
from .._validate import FloatArray, as_transform, as_vector
from ..errors import (
    InvalidParameterError,
    NonFiniteError,
    RedresError,
    ShapeError,
)
from . import _chain_codes
from ._frames import Reference

__all__ = ["ChainPoseError", "NotSerialChainError", "SerialChain", "log3"]

#: The serial-chain kernels (pose, Jacobians, pose error, log3). Cold: 4.5 s.
KERNELS = _compile.KernelGroup("chain", ("redres.robot._chain_kernels",), cold_seconds=4.5)

# Pinocchio joint kind -> name of its kind code in the kernel module
_JOINT_KINDS: dict[str, str] = {
    "JointModelRX": "REVOLUTE_X",
    "JointModelRY": "REVOLUTE_Y",
    "JointModelRZ": "REVOLUTE_Z",
    "JointModelRUBX": "REVOLUTE_X",
    "JointModelRUBY": "REVOLUTE_Y",
    "JointModelRUBZ": "REVOLUTE_Z",
    "JointModelRevoluteUnaligned": "REVOLUTE",
    "JointModelRevoluteUnboundedUnaligned": "REVOLUTE",
    "JointModelPX": "PRISMATIC",
    "JointModelPY": "PRISMATIC",
    "JointModelPZ": "PRISMATIC",
    "JointModelPrismaticUnaligned": "PRISMATIC",
}
_WHY: dict[str, str] = {
    "JointModelFreeFlyer": "a free-flyer (floating base, 6 DOF)",
    "JointModelSpherical": "a spherical joint (3 DOF)",
    "JointModelSphericalZYX": "a spherical joint (3 DOF)",
    "JointModelPlanar": "a planar joint (3 DOF)",
    "JointModelTranslation": "a translation joint (3 DOF)",
    "JointModelUniversal": "a universal joint (2 DOF)",
    "JointModelMimic": "a mimic joint (it moves with another joint)",
    "JointModelComposite": "a composite joint",
    **{f"JointModel{axis}": "a helical joint (a screw)" for axis in ("HX", "HY", "HZ")},
    "JointModelHelicalUnaligned": "a helical joint (a screw)",
}
_F64 = np.dtype(np.float64)
_KIND_CODES: dict[str, int] = {}  # from redres.robot._chain_codes on first use


class NotSerialChainError(RedresError, ValueError):
    """The model is not a serial chain of one-DOF revolute or prismatic joints up to the
    frame (the message names the joint and why); use the Pinocchio path instead."""


@dataclass(frozen=True)
class ChainPoseError:
    """Pose, world-aligned Jacobian and frame-task error from one kernel call.

    Attributes:
        pose: the frame's pose in the world, ``(4, 4)``.
        jacobian: its geometric Jacobian, world-aligned, ``(6, n)``, rows ``[v; ω]``.
        error: ``[p_d − p; log(R_d Rᵀ)]``, ``(6,)``, m and rad, world-aligned.
    """

    pose: FloatArray
    jacobian: FloatArray
    error: FloatArray


class SerialChain:
    """Compiled kinematics of the chain from the base to one frame of a Pinocchio model.

    Args:
        model: the Pinocchio model (read once; later changes to it are not seen).
        frame: the frame's name or index in ``model.frames``.

    Raises:
        NotSerialChainError: a joint between the base and the frame is not a one-DOF
            revolute or prismatic joint, or the model branches before the frame.
        FrameNotFoundError: ``frame`` is not a frame of the model (a name).

    Attributes:
        frame: the frame's name.
        n: columns of the Jacobian and size of ``q`` (``model.nv``).
        joints: names of the chain's ``k`` joints, base first (``q[:k]`` are theirs;
            joints after the frame get zero columns).
    """

    def __init__(self, model: pin.Model, frame: str | int) -> None:
        """The arguments are described in ``help(SerialChain)``."""
        frame_id = _frame_index(model, frame)
        self.frame = str(model.frames[frame_id].name)
        self.n = int(model.nv)
        path = _path(model, frame_id, self.frame)
        codes = _kind_codes()
        k = len(path)
        links = np.empty((k + 1, 3, 4))
        axes = np.empty((k, 3))
        kinds = np.empty(k, dtype=np.int64)
        for row, j in enumerate(path):
            joint = model.joints[j]
            kind = _JOINT_KINDS[joint.shortname()]
            links[row] = model.jointPlacements[j].homogeneous[:3]
            axes[row] = _axis(joint, kind)
            kinds[row] = codes[kind]
        links[k] = model.frames[frame_id].placement.homogeneous[:3]
        self.joints = tuple(str(model.names[j]) for j in path)
        for array in (links, axes, kinds):
            array.flags.writeable = False
        self._arrays = (links, axes, kinds)

    # ------------------------------------------------------------------ kernels
    @property
    def arrays(self) -> tuple[FloatArray, FloatArray, Any]:
        """``(links (k + 1, 3, 4), axes (k, 3), kinds (k,) int64)``: the joint placements
        in their parents and, last, the frame's in its joint; the joint axes; the joint
        kinds. The leading arguments of every kernel of
        :mod:`redres.robot._chain_kernels` (read-only, C-contiguous)."""
        return self._arrays

    @property
    def prismatic(self) -> NDArray[np.bool_]:
        """``(k,)``: which joints of the chain are prismatic (the rest are revolute)."""
        return self._arrays[2] == _chain_codes.PRISMATIC

    @staticmethod
    def kernel(name: Literal["fk", "jacobian", "pose_error", "log3"]) -> Any:
        """The compiled kernel ``name``, as a native entry point for float64 C-contiguous
        arrays, ``kinds`` int64 and ``local`` a bool (the plain-Python function when
        ``REDRES_DISABLE_JIT=1``). Signatures, writing into the last arguments::

            fk(links, axes, kinds, q, T)
            jacobian(links, axes, kinds, q, local, T, J)
            pose_error(links, axes, kinds, q, target, T, J, e)
            log3(R, out)

        with ``q (n,)``, ``T (4, 4)``, ``J (6, n)``, ``target (4, 4)``, ``e (6,)``,
        ``R (3, 3)``, ``out (3,)``. The first three return False when ``q`` holds NaN or
        ±inf (the one check they make), ``log3`` when ``R`` does; shapes and types are
        not checked.
        """
        return _entry(name)

    # ------------------------------------------------------------------ checked calls
    def fk(self, q: Any, *, out: FloatArray | None = None) -> FloatArray:
        """Pose of the frame in the world, ``(4, 4)``, at ``q`` ``(n,)`` (= Pinocchio
        ``oMf``); written into ``out`` when given."""
        T = _output(out, (4, 4), "out")
        qv = self._q(q)
        if not _entry("fk")(*self._arrays, qv, T):
            _nonfinite(qv)
        return T

    def jacobian(
        self, q: Any, reference: Reference = "world", *, out: FloatArray | None = None
    ) -> FloatArray:
        """Geometric Jacobian of the frame, ``(6, n)``, rows ``[v; ω]``, with the axes of
        :meth:`redres.robot.Robot.jacobian` (``"world"``: world-aligned; ``"local"``: the
        frame's own); written into ``out`` when given."""
        return self.kinematics(q, reference, jacobian=out)[1]

    def kinematics(
        self,
        q: Any,
        reference: Reference = "world",
        *,
        pose: FloatArray | None = None,
        jacobian: FloatArray | None = None,
    ) -> tuple[FloatArray, FloatArray]:
        """Pose ``(4, 4)`` and Jacobian ``(6, n)`` of the frame from one pass, written into
        ``pose`` and ``jacobian`` when given."""
        if reference not in ("world", "local"):
            raise InvalidParameterError(f"reference must be 'world' or 'local'; got {reference!r}")
        T = _output(pose, (4, 4), "pose")
        J = _output(jacobian, (6, self.n), "jacobian")
        qv = self._q(q)
        if not _entry("jacobian")(*self._arrays, qv, reference == "local", T, J):
            _nonfinite(qv)
        return T, J

    def pose_error(self, q: Any, T_target: Any, *, validate: bool = True) -> ChainPoseError:
        """Pose, world-aligned Jacobian and the frame task's error against ``T_target``
        (4x4, world): ``[p_d − p; log(R_d Rᵀ)]`` (docs/conventions.md, the error of
        :class:`redres.tasks.FrameTask`). ``validate=False`` skips the checks of
        ``T_target`` (finite, homogeneous, a rotation block; about 10 µs) for loops
        whose targets are already checked; its shape is always checked."""
        if validate:
            target = np.ascontiguousarray(as_transform(T_target, "T_target"))
        else:
            target = np.ascontiguousarray(T_target, dtype=np.float64)
            if target.shape != (4, 4):
                raise ShapeError(f"T_target must have shape (4, 4); got shape {target.shape}")
        T, J, e = np.empty((4, 4)), np.empty((6, self.n)), np.empty(6)
        qv = self._q(q)
        if not _entry("pose_error")(*self._arrays, qv, target, T, J, e):
            _nonfinite(qv)
        return ChainPoseError(T, J, e)

    def __setstate__(self, state: dict[str, Any]) -> None:
        # Copies and pickles come back writeable: keep the kernels' read-only types.
        self.__dict__.update(state)
        for array in self._arrays:
            array.flags.writeable = False

    def __repr__(self) -> str:
        return f"SerialChain(frame={self.frame!r}, joints={len(self.joints)}, n={self.n})"

    def _q(self, q: Any) -> FloatArray:
        """``q`` as a C-contiguous float64 vector of size ``n``; its finiteness is checked
        by the kernels (they return False), not here."""
        if (
            type(q) is np.ndarray
            and q.dtype == np.float64
            and q.shape == (self.n,)
            and q.flags.c_contiguous
        ):
            return q
        return np.ascontiguousarray(as_vector(q, "q", self.n))


def _nonfinite(q: FloatArray) -> None:
    raise NonFiniteError(f"q contains NaN or infinity: {q}")


def log3(R: Any) -> FloatArray:
    """The SO(3) logarithm ``θ u`` of a rotation matrix ``(3, 3)``, ``(3,)``, rad, or of
    each of a stack ``(N, 3, 3)``, ``(N, 3)``: the one logarithm of redres, for Python
    code and kernels alike (the chain kernels' ``_rotation_log``: accurate at every angle,
    0 and π included; Sola et al. 2018, see :mod:`redres.robot._chain_kernels`).

    Raises:
        ShapeError: ``R`` is not ``(3, 3)`` or ``(N, 3, 3)``.
        NonFiniteError: ``R`` holds NaN or infinity (its logarithm would).
    """
    kernel = _entry("log3")
    if type(R) is np.ndarray and R.shape == (3, 3) and R.dtype == _F64 and R.flags.c_contiguous:
        out = np.empty(3)  # the common case, checked in one line (a third of the call)
        if not kernel(R, out):
            raise NonFiniteError("R contains NaN or infinity")
        return out
    M = np.ascontiguousarray(R, dtype=np.float64)
    if M.ndim not in (2, 3) or M.shape[-2:] != (3, 3):
        raise ShapeError(f"R must have shape (3, 3) or (N, 3, 3); got shape {M.shape}")
    if not np.isfinite(M).all():
        raise NonFiniteError("R contains NaN or infinity")
    out = np.empty(M.shape[:-1])
    for rotation, row in zip(M.reshape(-1, 3, 3), out.reshape(-1, 3), strict=True):
        kernel(rotation, row)
    return out


# ---------------------------------------------------------------------- extraction


def _frame_index(model: pin.Model, frame: str | int) -> int:
    from ..errors import FrameNotFoundError

    if isinstance(frame, (int, np.integer)) and 0 <= frame < len(model.frames):
        return int(frame)
    if isinstance(frame, str) and model.existFrame(frame):
        return int(model.getFrameId(frame))
    names = [str(f.name) for f in model.frames][1:]
    raise FrameNotFoundError(f"unknown frame {frame!r}; valid frames: {', '.join(names)}")


def _path(model: pin.Model, frame_id: int, frame: str) -> list[int]:
    """Joints from the base to ``frame``: they must be joints ``1 … k`` in order, each a
    one-DOF revolute or prismatic joint, else :class:`NotSerialChainError`."""
    where = f"frame {frame!r} of model {model.name!r}"
    fallback = "; use the Pinocchio path (Robot.fk, Robot.jacobian) for this frame"
    path = [int(j) for j in model.supports[model.frames[frame_id].parentJoint]][1:]
    off = [j for j in range(1, path[-1] + 1) if j not in path] if path else []
    if off:
        j = off[0]
        raise NotSerialChainError(
            f"{where}: joint {str(model.names[j])!r} is not on the chain from the base to "
            f"the frame (the model branches at {str(model.names[model.parents[j]])!r}), so it "
            f"is not a serial chain{fallback}"
        )
    for j in path:
        joint = model.joints[j]
        kind = str(joint.shortname())
        if kind not in _JOINT_KINDS:
            why = _WHY.get(kind, f"a {kind.removeprefix('JointModel')} joint")
            raise NotSerialChainError(
                f"{where}: joint {str(model.names[j])!r} is {why} (nq={joint.nq}, "
                f"nv={joint.nv}); compiled chains take one-DOF revolute and prismatic "
                f"joints only{fallback}"
            )
        if joint.idx_v != j - 1:  # pragma: no cover - joints 1 … k of nv = 1 come first
            raise NotSerialChainError(f"{where}: joint {str(model.names[j])!r} is out of order")
    return path


def _axis(joint: Any, kind: str) -> FloatArray:
    """The joint's axis in its own frame: the motion subspace ``S = [v; ω]`` of a one-DOF
    joint is ``[0; a]`` (revolute) or ``[a; 0]`` (prismatic)."""
    data = joint.createData()
    q = np.zeros(joint.nq)
    if joint.nq == 2:  # unbounded revolute: (cos, sin) of angle 0
        q[0] = 1.0
    joint.calc(data, q)
    S = np.asarray(data.S, dtype=float).reshape(6)
    axis = S[:3] if kind == "PRISMATIC" else S[3:]
    return axis / np.linalg.norm(axis)


# ---------------------------------------------------------------------- kernels


def _kind_codes() -> dict[str, int]:
    if not _KIND_CODES:
        for name in set(_JOINT_KINDS.values()):
            _KIND_CODES[name] = int(getattr(_chain_codes, name))
    return _KIND_CODES


def _module() -> Any:
    return KERNELS.required(
        "compiled chain kinematics", otherwise="use Robot.fk and Robot.jacobian"
    )


_ENTRIES: dict[str, Any] = {}


def _entry(name: str) -> Any:
    """Native entry point of kernel ``name`` for the types the methods pass (compiled or
    loaded from the cache on first use)."""
    entry = _ENTRIES.get(name)
    if entry is None:
        module = _module()
        if not _compile.is_compiled(module):  # its plain twin while it compiles behind: not
            return getattr(module, name)  # kept, so the compiled kernel takes over when ready
        chain = (np.zeros((2, 3, 4)), np.eye(3)[2:], np.array([2], dtype=np.int64))
        for array in chain:  # the types of SerialChain.arrays, read-only
            array.flags.writeable = False
        q, T, J, e = np.zeros(1), np.zeros((4, 4)), np.zeros((6, 1)), np.zeros(6)
        warm = {
            "fk": (*chain, q, T),
            "jacobian": (*chain, q, False, T, J),
            "pose_error": (*chain, q, np.eye(4), T, J, e),
            "log3": (np.eye(3), np.zeros(3)),
        }[name]
        entry = _ENTRIES[name] = _compile.entry_point(getattr(module, name), warm)
    return entry


def _output(out: FloatArray | None, shape: tuple[int, ...], name: str) -> FloatArray:
    """``out`` checked as a writeable float64 C-contiguous array of ``shape``, or a new one."""
    if out is None:
        return np.empty(shape)
    if (
        type(out) is not np.ndarray
        or out.shape != shape
        or out.dtype != np.float64
        or not out.flags.c_contiguous
        or not out.flags.writeable
    ):
        got = f"shape {getattr(out, 'shape', None)}, dtype {getattr(out, 'dtype', type(out))}"
        raise ShapeError(
            f"{name} must be a writeable C-contiguous float64 array of shape {shape}; got {got}"
        )
    return out
