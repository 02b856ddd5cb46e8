"""Payloads and gravity: modified copies of a robot, never the caller's robot.

A :class:`Payload` is a rigid body (mass, centre of mass, rotational inertia) fixed to a
frame of the robot. :func:`with_payload` returns a new :class:`~redres.Robot` whose
Pinocchio model carries it (``pin.Model`` copy + ``appendBodyToJoint``), so that
``M(q)``, ``b(q, q̇)`` and forward dynamics include the load.

Load independence (Featherstone & Khatib 1997): if a load with spatial inertia ``I_L`` is
rigidly attached to body B, then ``M_L = M + J_Bᵀ I_L J_B`` with ``J_B`` any 6-row
Jacobian of B. For the task ``J = J_B`` with full row rank, ``M_L J̄ = Jᵀ Λ + Jᵀ I_L J J̄ =
Jᵀ (Λ + I_L)``, so ``Λ_L = Λ + I_L`` and ``J̄_L = J̄``: the dynamically consistent inverse
(and hence the torque projector ``I − Jᵀ J̄ᵀ``) does not depend on the load, while ``Λ``
grows by exactly the load's spatial inertia expressed in the task coordinates
(:func:`payload_spatial_inertia`). tests/dynamics/test_payload.py checks which variants of
this statement hold (docs/dynamics.md reports the numbers).

Reference:
    R. Featherstone, O. Khatib, "Load independence of the dynamically consistent inverse
    of the Jacobian matrix", Int. J. Robotics Research 16(2), 1997, 168-170.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from .._validate import FloatArray, as_matrix, as_scalar, as_vector
from ..errors import InvalidParameterError, NotPositiveDefiniteError

if TYPE_CHECKING:
    from ..robot import Reference, Robot


def _inertia(value: Any) -> FloatArray:
    I = as_matrix(value, "inertia", (3, 3))
    if np.abs(I - I.T).max() > 1e-12 * max(1.0, np.abs(I).max()):
        raise NotPositiveDefiniteError(
            "inertia must be symmetric (kg·m², about the centre of mass, in the frame's axes)"
        )
    if np.linalg.eigvalsh(I).min() < -1e-12:
        raise NotPositiveDefiniteError("inertia must be positive semi-definite")
    return I.copy()


@dataclass(frozen=True)
class Payload:
    """A rigid load fixed to a robot frame.

    Attributes:
        mass: kg, ≥ 0.
        com: centre of mass in the frame's axes, relative to its origin, ``(3,)``, m.
        inertia: rotational inertia about the centre of mass, frame axes, ``(3, 3)``,
            kg·m², symmetric positive semi-definite (zeros: a point mass).
        frame: frame the load is fixed to (``None``: the robot's tip).
    """

    mass: float
    com: Any = (0.0, 0.0, 0.0)
    inertia: Any = field(default_factory=lambda: np.zeros((3, 3)))
    frame: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", as_scalar(self.mass, "mass", minimum=0.0))
        object.__setattr__(self, "com", as_vector(self.com, "com", 3).copy())
        object.__setattr__(self, "inertia", _inertia(self.inertia))

    def pinocchio_inertia(self) -> pin.Inertia:
        """The load as a Pinocchio ``Inertia`` about the frame origin, frame axes."""
        return pin.Inertia(self.mass, self.com, self.inertia)

    def spatial_inertia(self) -> FloatArray:
        """6x6 spatial inertia about the frame origin, frame axes, ``[linear; angular]``:
        ``[[m I, −m ĉ], [m ĉ, I_c − m ĉ ĉ]]`` (Featherstone, *Rigid Body Dynamics
        Algorithms*, 2008, eq. 2.63, reordered to linear-first)."""
        return np.array(self.pinocchio_inertia().matrix())


def with_payload(robot: Robot, payload: Payload, *, name: str | None = None) -> Robot:
    """A copy of ``robot`` carrying ``payload`` (the argument is left untouched).

    Args:
        payload: the load and the frame it is fixed to.
        name: name of the copy (default ``"<robot>+<mass>kg"``).

    Raises:
        FrameNotFoundError: ``payload.frame`` is not a frame of ``robot``.
    """
    if not isinstance(payload, Payload):
        raise InvalidParameterError(f"payload must be a Payload; got {payload!r}")
    fid = robot.frame_id(payload.frame)
    model = pin.Model(robot.model)
    frame = model.frames[fid]
    model.appendBodyToJoint(frame.parentJoint, payload.pinocchio_inertia(), frame.placement)
    return robot.derived(model, name=name or f"{robot.name}+{payload.mass:g}kg")


def with_gravity(
    robot: Robot, gravity: Any = (0.0, 0.0, -9.81), *, name: str | None = None
) -> Robot:
    """A copy of ``robot`` with another gravity vector (world, m/s²); ``(0, 0, 0)`` for
    gravity-free simulation. The argument is left untouched."""
    g = as_vector(gravity, "gravity", 3)
    model = pin.Model(robot.model)
    model.gravity = pin.Motion(g, np.zeros(3))
    return robot.derived(model, name=name or robot.name)


def payload_spatial_inertia(
    robot: Robot, q: Any, payload: Payload, frame: str | None = None, reference: Reference = "world"
) -> FloatArray:
    """Spatial inertia of ``payload`` about the origin of ``frame``, ``(6, 6)``.

    Expressed in the coordinates of ``robot.jacobian(q, frame, reference)``: world-aligned
    axes (``"world"``) or the frame's own (``"local"``), ``[linear; angular]``. When the
    load and the 6-row task are on the same body this is ``Λ_L − Λ`` (module docstring).

    Args:
        robot: the robot *without* the payload (its frames place the load).
        q: configuration, ``(n,)``.
        payload: the load.
        frame: task frame (``None``: the tip).
        reference: ``"world"`` or ``"local"``.
    """
    T_load = robot.fk(q, payload.frame)
    T_task = robot.fk(q, frame)
    # Inertia in the task frame, then (world) rotated to world-aligned axes.
    M_task_load = pin.SE3(np.linalg.solve(T_task, T_load))
    I_task = M_task_load.act(payload.pinocchio_inertia())
    if reference == "world":
        I_task = pin.SE3(T_task[:3, :3], np.zeros(3)).act(I_task)
    elif reference != "local":
        raise InvalidParameterError(f"reference must be 'world' or 'local'; got {reference!r}")
    return np.array(I_task.matrix())
