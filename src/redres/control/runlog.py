"""The record of one control run, its summary metrics and its warnings."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from .._validate import FloatArray
from .runwarnings import RunWarning, run_warnings


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
        when), singular configurations, a target not reached (the largest error); empty
        for a clean run. Each prints as its one-line message."""
        return run_warnings(self)

    def summary(self) -> dict[str, Any]:
        """Summary metrics with stable keys (``redres run --json`` and ``redres demo --json``
        print these).

        Besides the metrics: ``min_obstacle_clearance_m``, the smallest arm–obstacle
        distance over the whole run (only when obstacle distances were logged), and
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
        out["warnings"] = [w.as_dict() for w in self.warnings]
        return out
