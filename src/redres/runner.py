"""Run every scheme of a scenario, tell what went wrong, and tabulate the results.

:func:`summarise` is a run's summary for tables and ``--json``: :meth:`RunLog.summary`
plus the smallest arm–obstacle clearance over the whole run and the run's warnings
(:func:`run_warnings`): a joint that left its limits (which, by how much, when), singular
configurations (σ_min of the task Jacobian under :data:`SINGULAR_SIGMA`), and a target
not reached (position error over :data:`NOT_REACHED_M`, with the largest error).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from .control import RunLog, run
from .dynamics.simulate import simulate
from .objectives import ObstacleObjective
from .scenario import ScenarioSpec

if TYPE_CHECKING:
    from .robot import Robot

#: σ_min of the task Jacobian under this is a singular configuration (a warning).
SINGULAR_SIGMA = 1e-3
#: A position error over this, m, means the run did not reach its target (a warning).
NOT_REACHED_M = 5e-3
#: A joint this far past a limit, rad or m, has left its limits (rounding is not).
LIMIT_TOL = 1e-9

WarningKind = Literal["joint_limits", "singular", "not_reached"]


@dataclass(frozen=True)
class RunWarning:
    """Something a run did that its user should know, in one line.

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
        """Plain JSON types."""
        return asdict(self)


def _intervals(mask: np.ndarray) -> int:
    """Number of runs of consecutive ``True`` in ``mask``."""
    m = np.asarray(mask, dtype=bool)
    return int(np.count_nonzero(m[1:] & ~m[:-1]) + (1 if m.size and m[0] else 0))


def run_warnings(robot: Robot, log: RunLog) -> list[RunWarning]:
    """The warnings of a run of ``robot`` (module docstring), in a fixed order."""
    out: list[RunWarning] = []
    excess = np.maximum(robot.q_min - log.q, log.q - robot.q_max)  # > 0 outside, (K, n)
    worst_per_joint = excess.max(axis=0)
    left = np.flatnonzero(worst_per_joint > LIMIT_TOL)
    if left.size:
        j = int(left[np.argmax(worst_per_joint[left])])
        k = int(np.argmax(excess[:, j]))
        side = "lower" if log.q[k, j] < robot.q_min[j] else "upper"
        others = f"; {left.size} joints left their limits" if left.size > 1 else ""
        steps = int(np.count_nonzero((excess > LIMIT_TOL).any(axis=1)))
        name = robot.joint_names[j]
        out.append(RunWarning(
            "joint_limits",
            f"joint {name!r} went {worst_per_joint[j]:.3g} rad past its {side} limit at "
            f"t = {log.t[k]:.3f} s ({steps} steps outside the limits{others})",
            float(worst_per_joint[j]), float(log.t[k]), name, steps,
        ))  # fmt: skip
    singular = log.sigma_min < SINGULAR_SIGMA
    if singular.any():
        k = int(np.argmin(log.sigma_min))
        count = int(singular.sum())
        events = _intervals(singular)
        out.append(RunWarning(
            "singular",
            f"singular: σ_min of the task Jacobian fell to {log.sigma_min[k]:.2g} at "
            f"t = {log.t[k]:.3f} s (under {SINGULAR_SIGMA:g} for {count} steps, "
            f"{events} event{'s' if events > 1 else ''})",
            float(log.sigma_min[k]), float(log.t[k]), steps=count,
        ))  # fmt: skip
    far = log.position_error > NOT_REACHED_M
    if far.any():
        k = int(np.argmax(log.position_error))
        out.append(RunWarning(
            "not_reached",
            f"target not reached: position error up to {1e3 * log.position_error[k]:.1f} mm "
            f"at t = {log.t[k]:.3f} s (over {1e3 * NOT_REACHED_M:g} mm for "
            f"{int(far.sum())} steps; final {1e3 * log.position_error[-1]:.1f} mm)",
            float(log.position_error[k]), float(log.t[k]), steps=int(far.sum()),
        ))  # fmt: skip
    return out


def summarise(robot: Robot, log: RunLog) -> dict[str, Any]:
    """:meth:`RunLog.summary` plus ``min_obstacle_clearance_m`` (the smallest arm–obstacle
    distance over the whole run, when obstacles were logged) and ``warnings`` (a list of
    :meth:`RunWarning.as_dict`)."""
    out = log.summary()
    distance = log.objectives.get("obstacle_distance_m")
    if distance is not None and len(distance):
        out["min_obstacle_clearance_m"] = float(np.min(distance))
    out["warnings"] = [w.as_dict() for w in run_warnings(robot, log)]
    return out


def warning_lines(summaries: Sequence[dict[str, Any]]) -> list[str]:
    """One line per warning of the summaries: ``warning: ROBOT LABEL: MESSAGE``."""
    return [
        f"warning: {s.get('robot', '')} {s.get('label', '')}: {w['message']}"
        for s in summaries
        for w in s.get("warnings", ())
    ]


COLUMNS = (
    ("robot", "robot", "{}"),
    ("label", "scheme", "{}"),
    ("max_position_error_m", "max err mm", "{:.4f}"),
    ("rms_position_error_m", "rms err mm", "{:.4f}"),
    ("min_joint_limit_margin_rad", "min margin rad", "{:+.3f}"),
    ("min_sigma", "min sigma", "{:.3f}"),
    ("min_obstacle_clearance_m", "clearance mm", "{:+.1f}"),
    ("peak_speed_ratio", "peak qd/qd_max", "{:.2f}"),
    ("path_length_rad", "path rad", "{:.2f}"),
    ("step_time_us_median", "step us", "{:.1f}"),
)
_MM = {"max_position_error_m", "rms_position_error_m", "min_obstacle_clearance_m"}
_OPTIONAL = {"min_obstacle_clearance_m"}  # shown when a run has it


def run_scenario(spec: ScenarioSpec, *, progress: bool | None = None) -> list[RunLog]:
    """Run each scheme of ``spec`` from the same start; returns the logs in order."""
    extra = [ObstacleObjective(spec.obstacles)] if spec.obstacles else []
    logs = []
    for s in spec.schemes:
        common: dict[str, Any] = {"dt": spec.dt, "duration": spec.duration, "q0": spec.q0,
                                  "label": s.label, "progress": progress}  # fmt: skip
        if s.kind == "osc":
            logs.append(simulate(spec.robot, s.build(), spec.trajectory, **common))
        else:
            logs.append(run(spec.robot, spec.task(), spec.trajectory, s.build(), gain=spec.gain,
                            log_objectives=extra, **common))  # fmt: skip
    return logs


def aligned_table(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """``rows`` of text under ``headers``, in left-aligned columns below a rule."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(headers)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(headers, widths))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths)) for r in rows]
    return "\n".join(line.rstrip() for line in lines)


def format_table(summaries: Sequence[dict[str, Any]]) -> str:
    """The comparison table as aligned text."""
    columns = [c for c in COLUMNS if c[0] not in _OPTIONAL or any(c[0] in s for s in summaries)]
    rows = []
    for s in summaries:
        row = []
        for key, _, fmt in columns:
            value = s.get(key, "")
            if key in _MM and isinstance(value, float):
                value = value * 1e3
            row.append(fmt.format(value) if value != "" else "-")
        rows.append(row)
    return aligned_table([title for _, title, _ in columns], rows)
