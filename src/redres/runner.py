"""Run every scheme of a scenario and tabulate the results."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from .control import RunLog, run
from .dynamics import simulate
from .objectives import ObstacleObjective
from .scenario import ScenarioSpec

COLUMNS = (
    ("robot", "robot", "{}"),
    ("label", "scheme", "{}"),
    ("max_position_error_m", "max err mm", "{:.4f}"),
    ("rms_position_error_m", "rms err mm", "{:.4f}"),
    ("min_joint_limit_margin_rad", "min margin rad", "{:+.3f}"),
    ("min_sigma", "min sigma", "{:.3f}"),
    ("peak_speed_ratio", "peak qd/qd_max", "{:.2f}"),
    ("path_length_rad", "path rad", "{:.2f}"),
    ("step_time_us_median", "step us", "{:.1f}"),
)
_MM = {"max_position_error_m", "rms_position_error_m"}


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
    rows = []
    for s in summaries:
        row = []
        for key, _, fmt in COLUMNS:
            value = s.get(key, "")
            if key in _MM and isinstance(value, float):
                value = value * 1e3
            row.append(fmt.format(value) if value != "" else "-")
        rows.append(row)
    return aligned_table([title for _, title, _ in COLUMNS], rows)
