"""What a run did that its user should know: the warnings of a :class:`~redres.control.RunLog`
(``log.warnings``, ``log.summary()["warnings"]``; the kinds are described on
:class:`RunWarning`).

The thresholds are absolute, in the units of the log, and deliberately loose: a warning
marks a run whose table row needs a second look, not a failed test.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

if TYPE_CHECKING:
    from .runlog import RunLog

#: σ_min of the task Jacobian under this is a singular configuration (a warning).
SINGULAR_SIGMA = 1e-3
#: A position error over this, m, means the run did not reach its target (a warning).
NOT_REACHED_M = 5e-3
#: A joint this far past a limit, rad or m, has left its limits (rounding is not).
LIMIT_TOL = 1e-9

WarningKind = Literal["joint_limits", "singular", "not_reached"]


@dataclass(frozen=True)
class RunWarning:
    """Something a run did that its user should know, in one line; a run's
    :attr:`RunLog.warnings <redres.control.RunLog.warnings>` lists them in this order:

    - ``joint_limits``: a joint went more than ``1e-9`` past a position limit: the joint
      that went furthest, by how much (rad, or m for a prismatic joint), when, and how many
      steps the run spent outside any limit. The limits are those the run recorded
      (``log.q_min``, ``log.q_max``); a log built without them has no such warning.
    - ``singular``: σ_min of the task Jacobian fell under ``SINGULAR_SIGMA = 1e-3``: its
      smallest value, when, for how many steps and in how many separate events.
    - ``not_reached``: the position error went over ``NOT_REACHED_M = 5e-3`` m: the
      largest error, when, for how many steps, and the final error.

    ``str(warning)`` is its message.

    Attributes:
        kind: ``"joint_limits"``, ``"singular"`` or ``"not_reached"``.
        message: the line printed by ``redres run`` and ``redres demo``.
        value: the worst figure: how far past the limit (rad or m), the smallest σ_min, or
            the largest position error (m).
        t: the time of that figure, s.
        joint: the joint concerned (``joint_limits`` only).
        steps: how many steps it lasted.
    """

    kind: WarningKind
    message: str
    value: float
    t: float
    joint: str | None = None
    steps: int = 0

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON types (the ``warnings`` entries of ``--json``)."""
        return asdict(self)

    def __str__(self) -> str:
        return self.message


def _intervals(mask: np.ndarray) -> int:
    """Number of runs of consecutive ``True`` in ``mask``."""
    m = np.asarray(mask, dtype=bool)
    return int(np.count_nonzero(m[1:] & ~m[:-1]) + (1 if m.size and m[0] else 0))


def _joint_limits(log: RunLog) -> RunWarning | None:
    if log.q_min is None or log.q_max is None or not log.steps:
        return None
    excess = np.maximum(log.q_min - log.q, log.q - log.q_max)  # > 0 outside, (K, n)
    worst_per_joint = excess.max(axis=0)
    left = np.flatnonzero(worst_per_joint > LIMIT_TOL)
    if not left.size:
        return None
    j = int(left[np.argmax(worst_per_joint[left])])
    k = int(np.argmax(excess[:, j]))
    side = "lower" if log.q[k, j] < log.q_min[j] else "upper"
    others = f"; {left.size} joints left their limits" if left.size > 1 else ""
    steps = int(np.count_nonzero((excess > LIMIT_TOL).any(axis=1)))
    name = log.joint_names[j] if j < len(log.joint_names) else f"q[{j}]"
    return RunWarning(
        "joint_limits",
        f"joint {name!r} went {worst_per_joint[j]:.3g} rad past its {side} limit at "
        f"t = {log.t[k]:.3f} s ({steps} steps outside the limits{others})",
        float(worst_per_joint[j]), float(log.t[k]), name, steps,
    )  # fmt: skip


def _singular(log: RunLog) -> RunWarning | None:
    singular = log.sigma_min < SINGULAR_SIGMA
    if not singular.any():
        return None
    k = int(np.argmin(log.sigma_min))
    count = int(singular.sum())
    events = _intervals(singular)
    return RunWarning(
        "singular",
        f"singular: σ_min of the task Jacobian fell to {log.sigma_min[k]:.2g} at "
        f"t = {log.t[k]:.3f} s (under {SINGULAR_SIGMA:g} for {count} steps, "
        f"{events} event{'s' if events > 1 else ''})",
        float(log.sigma_min[k]), float(log.t[k]), steps=count,
    )  # fmt: skip


def _not_reached(log: RunLog) -> RunWarning | None:
    error = log.position_error
    far = error > NOT_REACHED_M
    if not far.any():
        return None
    k = int(np.argmax(error))
    return RunWarning(
        "not_reached",
        f"target not reached: position error up to {1e3 * error[k]:.1f} mm "
        f"at t = {log.t[k]:.3f} s (over {1e3 * NOT_REACHED_M:g} mm for "
        f"{int(far.sum())} steps; final {1e3 * error[-1]:.1f} mm)",
        float(error[k]), float(log.t[k]), steps=int(far.sum()),
    )  # fmt: skip


def run_warnings(log: RunLog) -> list[RunWarning]:
    """The warnings of ``log`` (module docstring), in a fixed order; use
    :attr:`RunLog.warnings <redres.control.RunLog.warnings>`."""
    found = (_joint_limits(log), _singular(log), _not_reached(log))
    return [w for w in found if w is not None]
