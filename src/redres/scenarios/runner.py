"""Run every scheme of a scenario, tell what went wrong, and tabulate the results.

A run's summary, with its warnings, is :meth:`RunLog.summary` (the warnings themselves are
:attr:`RunLog.warnings`, :class:`~redres.control.RunWarning`); :func:`summarise` is that
summary for a run of a given robot, and :func:`warning_lines` prints the warnings one
line each.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from ..control import LiveView, RunLog, run
from ..control.analysis import collision_clearance
from ..dynamics.simulate import simulate
from ..errors import MissingDependencyError
from ..objectives import ObstacleObjective
from .spec import ScenarioSpec

if TYPE_CHECKING:
    from ..robot import Robot


__all__ = [
    "aligned_table",
    "column_table",
    "format_table",
    "run_scenario",
    "summarise",
    "warning_lines",
]

_Record = TypeVar("_Record")


def summarise(robot: Robot, log: RunLog) -> dict[str, Any]:
    """:meth:`RunLog.summary` of a run of ``robot`` (tables, ``--json``); a log that did not
    record its joint limits (one built by hand) is measured against ``robot``'s. A robot
    without velocity limits has no ``peak_speed_ratio`` (None: a dash in the tables). A
    run under the collision constraint adds ``collision_binding_steps`` (steps where a
    collision row bound the velocity) and ``max_position_error_where_bound_m``."""
    if log.q_min is None or log.q_max is None:
        log = replace(log, joint_names=tuple(robot.joint_names), q_min=robot.q_min.copy(),
                      q_max=robot.q_max.copy())  # fmt: skip
    out = log.summary()
    record = log.extra.get("collision_pairs")
    if record is not None and record.constrained:  # where a collision row bound q̇: the
        bound = np.unique(record.step[record.binding])  # task yielded there, by how much
        out["collision_binding_steps"] = int(bound.size)
        error = log.position_error[bound]
        out["max_position_error_where_bound_m"] = float(error.max()) if error.size else 0.0
    if not np.isfinite(robot.qd_max).any():  # no velocity limit (an MJCF file): no ratio to it
        out["peak_speed_ratio"] = None
    return out


def warning_lines(summaries: Sequence[dict[str, Any]]) -> list[str]:
    """One line per warning of the summaries: ``warning: ROBOT LABEL: MESSAGE``."""
    return [
        f"warning: {s.get('robot', '')} {s.get('label', '')}: {w['message']}"
        for s in summaries
        for w in s.get("warnings", ())
    ]


#: The table's columns: summary key, header (a line break splits it in two, so that no
#: column is wider than its numbers), format.
COLUMNS = (
    ("robot", "robot", "{}"),
    ("label", "scheme", "{}"),
    ("max_position_error_m", "max\nerr\nmm", "{:.4f}"),
    ("rms_position_error_m", "rms\nerr\nmm", "{:.4f}"),
    ("min_joint_limit_margin_rad", "min\nmargin\nrad", "{:+.3f}"),
    ("min_sigma", "min\nsigma", "{:.3f}"),
    ("min_obstacle_clearance_m", "min\nclear\nmm", "{:+.1f}"),
    ("min_self_clearance_m", "min\nself\nmm", "{:+.1f}"),
    ("peak_speed_ratio", "peak\nqd/\nqd_max", "{:.2f}"),
    ("path_length_rad", "path\nrad", "{:.2f}"),
    ("step_time_us_median", "step\nus", "{:.1f}"),
)
#: Scheme labels longer than this go on to a second line (the table fits 100 columns).
LABEL_WIDTH = 28
_MM = {"max_position_error_m", "rms_position_error_m", "min_obstacle_clearance_m",
       "min_self_clearance_m"}  # fmt: skip
_OPTIONAL = {"min_obstacle_clearance_m", "min_self_clearance_m"}  # shown when a run has it


@dataclass(frozen=True)
class FrankaTarget:
    """Where ``redres run --robot franka://HOST`` (or ``--dry-run``) runs a scenario: the
    robot's ``address`` (None: the dry run on the model), the ``arm`` and the ``mode`` of
    the rate-control schemes (torque laws run in torque mode)."""

    address: str | None
    arm: str = "fr3"
    mode: str = "velocity"
    hand: bool = False


def run_scenario(
    spec: ScenarioSpec,
    *,
    progress: bool | None = None,
    viewer: LiveView | None = None,
    franka: FrankaTarget | None = None,
    skipped: list[tuple[str, str]] | None = None,
    after_each: Callable[[RunLog], None] | None = None,
) -> list[RunLog]:
    """Run each scheme of ``spec`` from the same start; returns the logs in order. A
    ``viewer`` shows the rate-control runs live as they are computed (``rr.run``'s
    ``viewer=``; torque-control runs are shown once finished). ``franka``: on a Franka
    arm (:func:`redres.hardware.run_on_franka`), one scheme after the other from where the
    robot stands. ``skipped``: a scheme whose optional dependency is missing is left out,
    with ``(label, message)`` appended here, instead of ending every run (without it the
    ``MissingDependencyError`` propagates). ``after_each``: called with each run's log as
    soon as it is done (a command's progress lines)."""
    extra = [ObstacleObjective(spec.obstacles)] if spec.obstacles else []
    logs = []
    if franka is not None:
        from ..hardware import run_on_franka

        for s in spec.schemes:
            torque = s.kind == "osc"
            logs.append(run_on_franka(
                franka.address, None if torque else spec.task(), spec.trajectory_from, s.build(),
                mode="torque" if torque else franka.mode, arm=franka.arm, hand=franka.hand,  # type: ignore[arg-type]
                duration=spec.duration, gain=spec.gain, label=s.label, progress=progress,
            ))  # fmt: skip
        return logs
    settings, compared = None, []  # the first scheme's collisions; runs measured against it
    for s in spec.schemes:
        common: dict[str, Any] = {"dt": spec.dt, "duration": spec.duration, "q0": spec.q0,
                                  "label": s.label, "progress": progress}  # fmt: skip
        try:
            if spec.plant == "mujoco":
                logs.append(_on_mujoco(spec, s.build(), s.kind == "osc", common))
            elif s.kind == "osc":
                logs.append(simulate(spec.robot, s.build(), spec.trajectory, **common))
            else:
                scheme = s.build()
                logs.append(run(spec.robot, spec.task(), spec.trajectory, scheme,
                                gain=spec.gain, shaping=spec.shaping, log_objectives=extra,
                                viewer=viewer, **common))  # fmt: skip
                collisions = getattr(scheme, "collisions", None)
                if collisions is not None:  # the clearances the constraint kept
                    collision_clearance(logs[-1], spec.robot, collisions)
                    settings = settings or collisions
                else:
                    compared.append(logs[-1])
        except MissingDependencyError as exc:
            if skipped is None:
                raise
            skipped.append((s.label, str(exc)))
            continue
        if after_each is not None:
            after_each(logs[-1])
    if settings is not None:  # the other runs measured on the same pairs, for the table
        for log in compared:
            collision_clearance(log, spec.robot, settings, constrained=False)
    return logs


def _on_mujoco(spec: ScenarioSpec, law: Any, torque: bool, common: dict[str, Any]) -> RunLog:
    """One scheme of ``spec`` on MuJoCo's simulation of its MJCF robot (:mod:`redres.sim`):
    a torque law through joint torques, a scheme's controller through the position servos."""
    from ..sim import MujocoPlant, run_on_mujoco, simulate_on_mujoco

    assert spec.mjcf is not None  # the spec checked it
    plant = MujocoPlant(spec.mjcf, frame=spec.robot.tip, timestep=spec.dt)
    if torque:
        return simulate_on_mujoco(plant, law, spec.trajectory, robot=spec.robot, **common)
    return run_on_mujoco(plant, spec.task(), spec.trajectory, law, robot=spec.robot,
                         gain=spec.gain, shaping=spec.shaping, **common)  # fmt: skip


def aligned_table(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """``rows`` of text under ``headers``, in left-aligned columns below a rule. A header
    or a cell may hold line breaks: its lines stack in its column (a header's lines are
    aligned to the bottom, a row's cells to the top)."""
    split_headers = [h.split("\n") for h in headers]
    split_rows = [[c.split("\n") for c in r] for r in rows]
    widths = [
        max(map(len, [*h, *(line for r in split_rows for line in r[i])]))
        for i, h in enumerate(split_headers)
    ]

    def block(cells: list[list[str]], bottom: bool) -> list[str]:
        height = max(map(len, cells))
        padded = [([""] * (height - len(c)) + c) if bottom else (c + [""] * (height - len(c)))
                  for c in cells]  # fmt: skip
        return ["  ".join(p[k].ljust(w) for p, w in zip(padded, widths)).rstrip()
                for k in range(height)]  # fmt: skip

    lines = block(split_headers, bottom=True)
    lines.append("  ".join("-" * w for w in widths))
    for r in split_rows:
        lines += block(r, bottom=False)
    return "\n".join(lines)


def column_table(
    columns: Sequence[tuple[str, Callable[[_Record], str]]], records: Iterable[_Record]
) -> str:
    """:func:`aligned_table` of ``records``, one row each, given by column: ``columns``
    pairs a header with the function that writes that column's cell of a record."""
    return aligned_table(
        [h for h, _ in columns], [[cell(r) for _, cell in columns] for r in records]
    )


def _wrapped(label: str) -> str:
    """``label`` in lines of :data:`LABEL_WIDTH`, continuation lines indented; broken after
    its first colon when that gives two lines (``gradient projection:`` / ``joint
    limits``)."""
    if len(label) <= LABEL_WIDTH:
        return label
    head, colon, rest = label.partition(": ")
    if colon and len(head) < LABEL_WIDTH and len(rest) <= LABEL_WIDTH - 2:
        return f"{head}:\n  {rest}"
    first, *more = textwrap.wrap(label, LABEL_WIDTH)
    return "\n  ".join([first, *textwrap.wrap(" ".join(more), LABEL_WIDTH - 2)])


def format_table(summaries: Sequence[dict[str, Any]]) -> str:
    """The comparison table as aligned text, within 100 columns for labels of up to
    :data:`LABEL_WIDTH` characters (a longer one is wrapped)."""
    columns = [c for c in COLUMNS if c[0] not in _OPTIONAL or any(c[0] in s for s in summaries)]
    rows = []
    for s in summaries:
        row = []
        for key, _, fmt in columns:
            value = s.get(key, "")
            if key in _MM and isinstance(value, float):
                value = value * 1e3
            text = fmt.format(value) if value not in ("", None) else "-"
            if key == "label":
                text = _wrapped(text)
            row.append(text)
        rows.append(row)
    return aligned_table([title for _, title, _ in columns], rows)
