"""Command shaping: joint velocities a real robot accepts, from any controller's command.

A robot's controller checks every command it receives against per-joint limits on
velocity, acceleration and jerk, each a finite difference of the command stream at the
control period: the Franka Panda, for one, aborts a 1 kHz motion at the first cycle whose
acceleration ``(q̇ₖ − q̇ₖ₋₁)/dt`` or jerk exceeds them. A CLIK law does not respect them by
construction: a gain of 50/s turns a 3 mrad offset between the measured state and the
reference into a 0.15 rad/s step of velocity in one millisecond, 150 rad/s².

:class:`CommandShaper` is an output stage any controller can end in. Each cycle it turns
the wanted velocity ``u`` into the velocity closest to it that keeps every limit, starting
from the robot's measured velocity and acceleration (continuous from the first cycle):

* per joint, the acceleration of the cycle is the one from which lowering it at the jerk
  limit (``h = j_max dt`` a cycle) down to zero lands the velocity exactly on ``u``
  (time-optimal approach without overshoot, in the discrete time the robot checks in);
* clipped to ``[a − h, a + h]`` (jerk) and ``[−a_max, a_max]`` (acceleration), with ``u``
  clipped to ``[−v_max, v_max]`` first;
* synchronised (the default): each joint covers the same fraction ``f`` of its way
  ``u − q̇`` this cycle, the smallest fraction any joint can (``q̇ ← q̇ + f (u − q̇)``, still
  clipped to each joint's bounds). A joint that alone would be slow does not bend the
  command's direction: the shaped velocity moves along the segment from the last one to
  the wanted one, so the task velocity ``J q̇`` keeps the direction the controller asked
  for while the robot catches up (each joint on its own would let a fast joint run ahead
  of a slow one, and a task-space loop chase the error that makes).

Lowering the acceleration by ``h`` a cycle is always allowed and never overshoots, so a
state that can land keeps being able to: from a start at rest, or any measured state that
keeps the limits, no command exceeds a limit, and a constant ``u`` is reached in the
least number of cycles the limits allow (then held exactly). Limits are aimed at one part
in a thousand inside (``margin``), as libfranka's own rate limiter aims inside the robot's
check, so that rounding in the robot's differences never decides a comparison.

Why this method: it is exact for the check the robot makes (finite differences at its own
period, not a continuous-time bound), needs no plan of the future (the target is the
controller's output, new every cycle), reduces to the controller's own command whenever
that command is feasible, and runs in a compiled kernel of this package (about 1 µs a
cycle for seven joints, from Python). An online trajectory generator (Ruckig: Berscheid
and Kröger, "Jerk-limited Real-time Trajectory Generation with Arbitrary Target States",
RSS 2021) plans a whole time-optimal profile to a target state each cycle; for a velocity
target without synchronisation of the joints it gives nearly the same stream
(``benchmarks/shaping.py`` compares the two). The cost is a lag: while a limit binds the
robot is behind the controller's wish, and a closed loop on the measured position makes
that up (the run log's tracking error shows what it costs).

A joint-position interface takes the integral of the shaped velocity (``q + q̇ dt``, which
is what :meth:`redres.control.Controller.step` returns): its finite differences are the
same stream.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .. import _compile
from .._validate import FloatArray, as_scalar, as_vector, real_array
from ..errors import InvalidParameterError, NonFiniteError, ShapeError

if TYPE_CHECKING:
    from ..robot import Robot

#: The shaper's kernel; cold: about 1 s.
KERNELS = _compile.KernelGroup("shaping", ("redres.control._shaping_kernels",), cold_seconds=1.0)

#: Default fraction of each limit kept in hand.
MARGIN = 1e-3


class CommandShaper:
    """Shapes a joint-velocity command, cycle by cycle, into one within velocity,
    acceleration and jerk limits, continuous from the measured state (module docstring).

    Args:
        qd_max: joint velocity limits, rad/s (a number for every joint, or shape ``(n,)``;
            ``inf``: none).
        qdd_max: joint acceleration limits, rad/s².
        qddd_max: joint jerk limits, rad/s³.
        dt: the control period, s: the period at which the robot differences the stream.
        margin: fraction of each limit kept in hand, in ``[0, 0.5]``.
        synchronized: every joint covers the same fraction of the way to its wanted
            velocity each cycle (the smallest any joint can), which keeps the shaped
            velocity on the segment from the last one to the wanted one (module
            docstring); ``False``: each joint on its own, as fast as it can.
        n: the number of joints, when every limit is a number.

    Use :meth:`for_robot` for a robot's own limits. ``shaper.reset(qd, qdd)`` with the
    robot's measured state before the first cycle (default: at rest), then
    ``qd = shaper(qd_wanted)`` each cycle.

    Raises:
        InvalidParameterError: a limit that is not positive, no finite acceleration or
            jerk limit at all (nothing to shape), or a bad ``dt`` or ``margin``.
        ShapeError: limits of different lengths.
    """

    def __init__(
        self,
        qd_max: Any,
        qdd_max: Any,
        qddd_max: Any,
        dt: float = 1e-3,
        *,
        margin: float = MARGIN,
        synchronized: bool = True,
        n: int | None = None,
    ) -> None:
        """The arguments are described in ``help(CommandShaper)``."""
        self.dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
        self.margin = as_scalar(margin, "margin", minimum=0.0)
        self.synchronized = bool(synchronized)
        if self.margin > 0.5:
            raise InvalidParameterError(f"margin must be at most 0.5; got {margin}")
        given = {"qd_max": qd_max, "qdd_max": qdd_max, "qddd_max": qddd_max}
        sizes = {np.size(v) for v in given.values()} - {1}
        if len(sizes) > 1:
            raise ShapeError(f"qd_max, qdd_max and qddd_max have different lengths {sizes}")
        n = sizes.pop() if sizes else n
        if n is None:
            raise InvalidParameterError("every limit is a number: give the number of joints n")
        rows = []
        for name, value in given.items():
            given_row = real_array(value, name, "a number or a vector")
            if given_row.ndim > 1:
                raise ShapeError(f"{name} must be a number or shape ({n},); got {given_row.shape}")
            row = np.broadcast_to(given_row, (n,))
            if not np.all(row > 0.0):  # NaN fails too
                raise InvalidParameterError(f"{name} must be positive (inf: none); got {row}")
            rows.append(row)
        self.limits: FloatArray = np.array(rows, dtype=float)
        if np.all(np.isinf(self.limits[1:])):
            raise InvalidParameterError(
                "no finite acceleration or jerk limit: there is nothing to shape to; give "
                "qdd_max and qddd_max (robot.with_limits(qdd_max=..., qddd_max=...))"
            )
        self._aim = self.limits * (1.0 - self.margin)
        self.n = n
        self._state = np.zeros((2, n))
        self._out = np.empty(n)
        self._kernel: Any = None
        self._pending = False

    @classmethod
    def for_robot(cls, robot: Robot, dt: float = 1e-3, *, margin: float = MARGIN) -> CommandShaper:
        """A shaper to ``robot``'s ``qd_max``, ``qdd_max`` and ``qddd_max``
        (:meth:`redres.Robot.with_limits` sets them; the Panda and FR3 models carry the
        published ones)."""
        return cls(robot.qd_max, robot.qdd_max, robot.qddd_max, dt, margin=margin)

    def reset(self, qd: Any = None, qdd: Any = None) -> None:
        """Start from the measured joint velocity ``qd`` and acceleration ``qdd`` (default:
        at rest): the robot's last commanded ones, which its check differences against."""
        self._state[0] = 0.0 if qd is None else as_vector(qd, "qd", self.n)
        self._state[1] = 0.0 if qdd is None else as_vector(qdd, "qdd", self.n)

    @property
    def qd(self) -> FloatArray:
        """The last shaped velocity, ``(n,)``, rad/s."""
        return self._state[0].copy()

    @property
    def qdd(self) -> FloatArray:
        """The last shaped acceleration, ``(n,)``, rad/s²."""
        return self._state[1].copy()

    def __call__(self, qd: Any) -> FloatArray:
        """This cycle's velocity, ``(n,)``, rad/s, for the wanted velocity ``qd``.

        Raises:
            ShapeError: ``qd`` does not have shape ``(n,)``.
            NonFiniteError: ``qd`` holds NaN or infinity.
        """
        u = real_array(qd, "qd")  # a float64 array passes as it is; complex is refused
        if u.shape != (self.n,):
            raise ShapeError(f"qd must have shape ({self.n},); got {u.shape}")
        if self._kernel is None or (self._pending and KERNELS.ready()):
            self._bind(u)
        if not self._kernel(u, self._aim, self.dt, self.synchronized, self._state, self._out):
            raise NonFiniteError(f"qd must be finite to be shaped; got {u}")
        return self._out.copy()

    def _bind(self, u: FloatArray) -> None:
        """The kernel's entry point: compiled once it is ready, its plain-Python twin while
        it compiles behind (asked again each cycle until then)."""
        module = KERNELS.required("command shaping")
        # entry_point runs the kernel once: on copies, so that the state does not advance
        args = (u, self._aim, self.dt, self.synchronized, self._state.copy(), self._out.copy())
        self._kernel = _compile.entry_point(module.shape, args)
        self._pending = _compile.enabled() and not _compile.is_compiled(module)

    def __repr__(self) -> str:
        return f"CommandShaper(n={self.n}, dt={self.dt}, margin={self.margin})"


def as_shaper(shaping: bool | CommandShaper, robot: Robot, dt: float) -> CommandShaper | None:
    """The shaper a controller's ``shaping`` argument asks for: ``True``, one of
    ``robot``'s limits; ``False``, None; a :class:`CommandShaper` for ``robot`` at ``dt``."""
    if isinstance(shaping, CommandShaper):
        if shaping.n != robot.n or shaping.dt != dt:
            raise InvalidParameterError(
                f"the shaper is for {shaping.n} joints at dt = {shaping.dt} s; the controller "
                f"drives {robot.n} at dt = {dt} s"
            )
        return shaping
    if shaping is True:
        return CommandShaper.for_robot(robot, dt)
    if shaping is False:
        return None
    raise InvalidParameterError(f"shaping must be True, False or a CommandShaper; got {shaping!r}")
