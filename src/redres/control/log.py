"""The record of one control run (:class:`RunLog`), its summary metrics, and what it did
that its user should know: its warnings (``log.warnings``, ``log.summary()["warnings"]``;
the kinds are described on :class:`RunWarning`).

The thresholds are absolute, in the units of the log, and deliberately loose: a warning
marks a run whose table row needs a second look, not a failed test.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import Any, Literal

import numpy as np

from .._validate import FloatArray

#: σ_min of the task Jacobian under this is a singular configuration (a warning).
SINGULAR_SIGMA = 1e-3
#: A position error over this, m, means the run did not reach its target (a warning).
NOT_REACHED_M = 5e-3
#: A joint this far past a limit, rad or m, has left its limits (rounding is not).
LIMIT_TOL = 1e-9

WarningKind = Literal["joint_limits", "collision", "self_collision", "singular", "not_reached"]


@dataclass(frozen=True)
class RunWarning:
    """Something a run did that its user should know, in one line; a run's
    :attr:`RunLog.warnings <redres.control.RunLog.warnings>` lists them in this order:

    - ``joint_limits``: a joint went more than ``1e-9`` past a position limit: the joint
      that went furthest, by how much (rad, or m for a prismatic joint), when, and how many
      steps the run spent outside any limit. The limits are those the run recorded
      (``log.q_min``, ``log.q_max``); a log built without them has no such warning.
    - ``collision``: the arm went into an obstacle (the arm–obstacle clearance, logged when
      the run has an obstacle objective, fell below zero): which obstacle and link, how
      deep (m), when, for how many steps and in how many separate events.
    - ``self_collision``: two link capsules went into each other (the self clearance,
      logged when the run is measured on collision pairs, fell below zero): which links,
      how deep, when, for how many steps and events.
    - ``singular``: σ_min of the task Jacobian fell under ``SINGULAR_SIGMA = 1e-3``: its
      smallest value, when, for how many steps and in how many separate events.
    - ``not_reached``: the position error went over ``NOT_REACHED_M = 5e-3`` m: the
      largest error, when, for how many steps, and the final error.

    ``str(warning)`` is its message.

    Attributes:
        kind: ``"joint_limits"``, ``"collision"``, ``"self_collision"``, ``"singular"``
            or ``"not_reached"``.
        message: the line printed by ``redres run`` and ``redres demo``.
        value: the worst figure: how far past the limit (rad or m), how deep into the
            obstacle (m), the smallest σ_min, or the largest position error (m).
        t: the time of that figure, s.
        joint: the joint concerned (``joint_limits``), the obstacle (``collision``) or
            the other link (``self_collision``).
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


def _collision(log: RunLog, self_pairs: bool = False) -> RunWarning | None:
    key, contact = (
        ("self", "deepest_self_contact") if self_pairs else ("obstacle", "deepest_contact")
    )
    distance = log.objectives.get(f"{key}_distance_m")
    if distance is None or not len(distance) or not distance.min() < 0.0:
        return None
    inside = distance < 0.0
    k = int(np.argmin(distance))
    names = log.extra.get(contact, {})  # the deepest pair, when the run was measured on pairs
    other = names.get("obstacle", "another link" if self_pairs else "an obstacle")
    link = names.get("link", "the arm")
    into = f"link {other!r}" if self_pairs else f"obstacle {other!r}"
    count, events = int(inside.sum()), _intervals(inside)
    return RunWarning(
        "self_collision" if self_pairs else "collision",
        f"{'self-collision' if self_pairs else 'collision'}: link {link!r} went "
        f"{1e3 * -distance[k]:.1f} mm into {into} at t = {log.t[k]:.3f} s ({count} steps "
        f"in contact, {events} event{'s' if events > 1 else ''})",
        float(-distance[k]), float(log.t[k]), str(other), count,
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
    found = (_joint_limits(log), _collision(log), _collision(log, self_pairs=True),
             _singular(log), _not_reached(log))  # fmt: skip
    return [w for w in found if w is not None]


@dataclass
class RunLog:
    """Everything a run recorded, one row per control step.

    Attributes:
        robot, scheme: names (``scheme`` is the stable identifier, e.g. ``pinv``).
        dt: control period, s.
        t: times, shape ``(K,)``, s.
        q, qd: joint positions and the velocities applied, shape ``(K, n)``.
        position: tip position, ``(K, 3)``, m; ``target``: reference position, ``(K, 3)``.
        position_error, orientation_error: norms of the task error, ``(K,)`` (m, rad);
            orientation is NaN-free zero when the task has no orientation rows.
        sigma_min, damping, rank: diagnostics of the inverse each step.
        speed_ratio: ``max |q̇ᵢ| / q̇_max,i`` of the applied velocity, ``(K,)``.
        scaled: steps where the command was scaled down to the velocity limits.
        joint_limit_margin: smallest signed distance to a position limit, ``(K,)``, rad.
        manipulability: ``√det(J Jᵀ)`` of the task Jacobian, ``(K,)``.
        objectives: value of each logged objective, name -> ``(K,)``.
        step_time_ns: wall time of each control step, ns.
        extra: scheme diagnostics worth keeping (e.g. algorithmic-singularity flags).
        joint_names, q_min, q_max: the robot's joint names and the position limits the run
            was measured against, ``(n,)`` (rad or m); recorded by :func:`~redres.run` and
            :func:`~redres.dynamics.simulate` (``None`` in a log built by hand, which then
            has no joint-limit warning).
    """

    robot: str
    scheme: str
    dt: float
    t: FloatArray
    q: FloatArray
    qd: FloatArray
    position: FloatArray
    target: FloatArray
    position_error: FloatArray
    orientation_error: FloatArray
    sigma_min: FloatArray
    damping: FloatArray
    rank: FloatArray
    speed_ratio: FloatArray
    scaled: FloatArray
    joint_limit_margin: FloatArray
    manipulability: FloatArray
    step_time_ns: FloatArray
    objectives: dict[str, FloatArray] = field(default_factory=dict)
    extra: dict[str, Any] = field(default_factory=dict)
    label: str = ""
    joint_names: tuple[str, ...] = ()
    q_min: FloatArray | None = None
    q_max: FloatArray | None = None

    @classmethod
    def empty(
        cls, robot: str, scheme: str, dt: float, steps: int, n: int, label: str = ""
    ) -> RunLog:
        """A log of ``steps`` rows for an ``n``-joint robot, to be filled in place:
        ``t = k dt``, every other array zero (``scaled`` False)."""
        widths = {"q": n, "qd": n, "position": 3, "target": 3}
        arrays: dict[str, Any] = {
            f.name: np.zeros((steps, widths[f.name]) if f.name in widths else steps)
            for f in fields(cls)
            if f.type == "FloatArray"
        }
        arrays["t"] = np.arange(steps, dtype=np.float64) * dt
        arrays["scaled"] = np.zeros(steps, dtype=bool)
        return cls(robot=robot, scheme=scheme, dt=dt, label=label, **arrays)

    @property
    def steps(self) -> int:
        """Number of control steps."""
        return int(self.t.shape[0])

    @property
    def warnings(self) -> list[RunWarning]:
        """What the run did that its user should know
        (:class:`~redres.control.RunWarning`): a joint past its limits (which, by how much,
        when), the arm inside an obstacle (which, how deep, when), singular configurations,
        a target not reached (the largest error); empty for a clean run. Each prints as its
        one-line message."""
        return run_warnings(self)

    def summary(self) -> dict[str, Any]:
        """Summary metrics with stable keys (``redres run --json`` and ``redres demo --json``
        print these).

        Besides the metrics: ``min_obstacle_clearance_m``, the smallest arm–obstacle
        distance over the whole run (only when obstacle distances were logged),
        ``min_self_clearance_m``, the smallest distance between two link capsules (only
        when logged: a run under collision avoidance with self pairs), and
        ``warnings``, :attr:`warnings` as a list of
        :meth:`~redres.control.RunWarning.as_dict`.
        """
        pe = self.position_error
        steps = np.diff(self.q, axis=0)
        path = float(np.sum(np.linalg.norm(steps, axis=1))) if self.steps > 1 else 0.0
        out: dict[str, Any] = {
            "robot": self.robot,
            "scheme": self.scheme,
            "label": self.label or self.scheme,
            "steps": self.steps,
            "dt_s": self.dt,
            "max_position_error_m": float(pe.max()) if pe.size else 0.0,
            "rms_position_error_m": float(np.sqrt(np.mean(pe**2))) if pe.size else 0.0,
            "max_orientation_error_rad": float(self.orientation_error.max()) if pe.size else 0.0,
            "min_joint_limit_margin_rad": float(self.joint_limit_margin.min()),
            "min_sigma": float(self.sigma_min.min()),
            "min_manipulability": float(self.manipulability.min()),
            "peak_speed_ratio": float(self.speed_ratio.max()),
            "scaled_steps": int(self.scaled.sum()),
            "path_length_rad": path,
            "step_time_us_median": float(np.median(self.step_time_ns) / 1e3),
        }
        for name, values in self.objectives.items():
            out[f"final_{name}"] = float(values[-1])
        distance = self.objectives.get("obstacle_distance_m")
        if distance is not None and len(distance):
            out["min_obstacle_clearance_m"] = float(np.min(distance))
        distance = self.objectives.get("self_distance_m")
        if distance is not None and len(distance):
            out["min_self_clearance_m"] = float(np.min(distance))
        out["warnings"] = [w.as_dict() for w in self.warnings]
        return out
