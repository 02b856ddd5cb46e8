"""``redres demo`` and ``redres run``: run scenarios, print the comparison, write a report.

The demo runs the built-in scenarios (``redres run --list``): the Panda circle that drives
plain pseudo-inverse control into a joint limit, under every scheme, and the iiwa14 figure
eight with its arm angle held by the augmented Jacobian. Textbook worked examples follow,
then the same Panda circle in the compiled 1 kHz loop (:func:`compiled_loop`).
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import linalg, models
from .._warmup import warmup
from ..control import LiveView, RunLog
from ..errors import MissingDependencyError
from ..objectives import JointLimitObjective
from ..report.writer import check_out_dir, write_report
from ..scenarios.planned import PlanComparison, compare_with_plan
from ..scenarios.runner import (
    FrankaTarget,
    format_table,
    run_scenario,
    summarise,
    warning_lines,
)
from ..scenarios.spec import ScenarioSpec, builtin

DEG = np.pi / 180
DEMO_SCENARIOS = ("panda_joint_limit_circle", "iiwa_arm_angle_eight")


def worked_examples() -> list[dict[str, object]]:
    """Classic planar worked examples and one null-space step on the Panda, computed live."""
    out: list[dict[str, object]] = []
    rrr = models.planar([1.0, 1.0, 1.0])
    J = rrr.jacobian(np.array([60.0, -30.0, 15.0]) * DEG)[:2]
    J_printed = np.round(J, 2)  # the classic example uses its Jacobian rounded to 2 decimals
    for weights in ([1.0, 2.0, 3.0], [3.0, 2.0, 1.0]):
        W = np.diag(weights)
        v = np.array([1.0, 1.0])
        out.append(
            {
                "example": "weighted least norm (Whitney 1969): RRR at (60, -30, 15) deg, "
                "v = (1, 1) m/s, "
                f"W = diag{tuple(weights)}",
                "qd_rad_s": np.round(linalg.weighted_pinv(J_printed, W) @ v, 2).tolist(),
                "qd_exact_jacobian_rad_s": np.round(linalg.weighted_pinv(J, W) @ v, 4).tolist(),
            }
        )
    rr_arm = models.planar([1.0, 1.0])
    J = rr_arm.jacobian(np.array([30.0, 30.0]) * DEG)[[0, 1, 5]]
    for v_list in ([1.0, 1.0, 1.0], [-2.0, 2.0, 2.0]):
        qd = linalg.left_pinv(J) @ np.array(v_list)
        out.append(
            {
                "example": f"left pseudo-inverse (Penrose 1955): RR at (30, 30) deg, "
                f"v = {tuple(v_list)}",
                "qd_rad_s": np.round(qd, 3).tolist(),
                "achieved_x": np.round(J @ qd, 3).tolist(),
            }
        )
    J = rr_arm.jacobian(np.array([30.0, 0.0]) * DEG)[:2]
    qd = linalg.pinv(J) @ np.array([-1.0, np.sqrt(3.0)])
    out.append(
        {
            "example": "SVD pseudo-inverse (Golub & Kahan 1965): singular RR at (30, 0) deg, "
            "v = (-1, sqrt 3)",
            "qd_rad_s": np.round(qd, 3).tolist(),
        }
    )
    panda = models.panda()
    q = panda.neutral()
    J = panda.jacobian(q)
    v = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    grad = JointLimitObjective().gradient(panda, q)  # Liégeois' joint-limit cost D(q)
    J_pinv = linalg.right_pinv(J)
    N = linalg.nullspace_projector(J, J_pinv)
    qd = J_pinv @ v - 1.0 * N @ grad
    out.append(
        {
            "example": "gradient projection (Liégeois 1977): Panda at its ready pose, "
            "v = 0.1 m/s along x, "
            "joint-limit gradient projected into the null space (k = 1)",
            "qd_rad_s": np.round(qd, 4).tolist(),
            "task_residual": float(np.linalg.norm(J @ qd - v)),
            "manipulability": float(linalg.manipulability(J)),
        }
    )
    return out


def compiled_loop(steps: int = 1500) -> list[dict[str, object]]:
    """The Panda circle's first ``steps`` under a :class:`~redres.control.Controller`:
    median µs per step (target update and step, timed inside the loop) and the largest
    position error, for gradient projection (the fused kernel) and, when the ``qp`` extra
    is there, the hard-limit schemes (the kernel's frame front end, then the scheme)."""
    from ..control import Controller
    from ..resolution import GradientProjectionScheme, QPScheme, Scheme, SNSScheme
    from ..tasks import FrameTask

    scenario = builtin("panda_joint_limit_circle")
    robot, trajectory = scenario.robot, scenario.trajectory
    schemes: dict[str, Callable[[], Scheme]] = {
        "gradient projection (fused kernel)": lambda: GradientProjectionScheme(
            [JointLimitObjective()], k_null=5.0
        ),
        "sns (hard limits)": lambda: SNSScheme(dt=1e-3),
        "qp (hard limits)": lambda: QPScheme(dt=1e-3),
    }
    rows: list[dict[str, object]] = []
    clock = time.perf_counter_ns
    for label, make in schemes.items():
        try:
            task = FrameTask()
            controller = Controller(robot, task, make())
        except MissingDependencyError:
            continue
        q, times, worst = scenario.q0.copy(), np.empty(steps), 0.0
        for k in range(steps):
            sample = trajectory.sample(k * 1e-3)
            t0 = clock()
            task.set_target(sample.pose, sample.twist, validate=False)
            q = controller.step(q)
            times[k] = clock() - t0
            worst = max(worst, float(np.linalg.norm(controller.error[:3])))
        rows.append({"loop": label, "median_us": round(float(np.median(times)) / 1e3, 1),
                     "max_error_mm": round(1e3 * worst, 4)})  # fmt: skip
    return rows


def _write_report(
    out: Path,
    runs: list[tuple[ScenarioSpec, RunLog]],
    title: str,
    description: str,
    force: bool,
    comparisons: Sequence[PlanComparison] = (),
) -> Path | None:
    pairs = [(spec.robot, log, spec.obstacles) for spec, log in runs]
    try:
        return Path(write_report(out, pairs, title=title, description=description, force=force,
                                 comparisons=comparisons))  # fmt: skip
    except MissingDependencyError as exc:
        print(f"redres: note: {exc}; no report written", file=sys.stderr)
        return None


def _run_done() -> Callable[[RunLog], None]:
    """A line on standard error as each run ends, where no progress bar shows (standard
    error is not a terminal: a CI log), so that a log never goes quiet for long."""
    last = [time.perf_counter()]

    def done(log: RunLog) -> None:
        now = time.perf_counter()
        if not sys.stderr.isatty():
            print(f"  {log.label or log.scheme}: {log.steps:,} steps in {now - last[0]:.1f} s",
                  file=sys.stderr, flush=True)  # fmt: skip
        last[0] = now

    return done


def _compile_for(specs: Sequence[ScenarioSpec], loud: bool) -> None:
    """Compile what the runs need before they are timed (on a cold cache they would
    otherwise run, and be timed, on the reference path while it compiles behind)."""
    groups = ["linalg", "derivatives", "chain", "controller"]
    if any(s.kind in ("qp", "sns") for spec in specs for s in spec.schemes):
        groups.append("hard limits")
    if any(s.kind == "osc" for spec in specs for s in spec.schemes):
        groups.append("dynamics")
    if any(spec.plan is not None for spec in specs):
        groups += ["analytic ik", "batch", "plan"]
    if any(spec.obstacles for spec in specs):  # clearances and the obstacle objective
        groups.append("collision")
    warmup(groups, quiet=not loud)


@dataclass(frozen=True)
class Output:
    """How a command reports (the command line's ``--out``, ``--force``, ``--json``,
    ``--quiet`` and ``--quick``).

    Attributes:
        folder: the report folder, checked before anything runs (a user's files are never
            replaced).
        as_json: print one JSON object instead of the table.
        quiet: print only the results.
        force: write the report into a folder that holds other files.
        quick: run 5 % of each scenario's duration (a smoke test of the whole pipeline).
    """

    folder: Path = Path("redres-report")
    as_json: bool = False
    quiet: bool = False
    force: bool = False
    quick: bool = False


def run_scenarios(
    specs: Sequence[ScenarioSpec],
    output: Output,
    *,
    title: str,
    examples: bool = False,
    after: Callable[[list[tuple[ScenarioSpec, RunLog]]], None] | None = None,
    viewer: LiveView | None = None,
    franka: FrankaTarget | None = None,
) -> int:
    """Run ``specs`` (shown live in ``viewer``, if given; on a Franka arm with
    ``franka``), print the table (or JSON), write the report, then hand the runs to
    ``after`` (``redres run --view`` serves them); returns the exit code."""
    as_json, quiet, quick = output.as_json, output.quiet, output.quick
    check_out_dir(output.folder, force=output.force)  # before any run
    started = time.perf_counter()
    loud = not (quiet or as_json)
    _compile_for(specs, loud)
    runs: list[tuple[ScenarioSpec, RunLog]] = []
    comparisons: list[PlanComparison] = []
    skipped: list[dict[str, str]] = []
    for spec in specs:
        if quick:
            spec.duration *= 0.05
        if loud:
            print(f"{spec.name}: {spec.description}", file=sys.stderr)
        missing: list[tuple[str, str]] = []
        logs = run_scenario(spec, progress=None if loud else False, viewer=viewer,
                            franka=franka, skipped=missing,
                            after_each=_run_done() if loud else None)  # fmt: skip
        runs += [(spec, log) for log in logs]
        if spec.plan is not None and logs:
            comparisons.append(against_plan(spec, logs, loud))
        skipped += [{"scenario": spec.name, "scheme": label, "reason": why}
                    for label, why in missing]  # fmt: skip
    if not runs and skipped:
        for miss in skipped:
            print(f"redres: {miss['scenario']}, {miss['scheme']}: {miss['reason']}",
                  file=sys.stderr)  # fmt: skip
        return 2
    description = " ".join(f"{s.description}." for s in specs)
    report = _write_report(output.folder, runs, title, description, output.force, comparisons)
    summaries = [summarise(spec.robot, log) for spec, log in runs]
    steps = 100 if quick else 1500
    if as_json:
        payload: dict[str, Any] = {"report": str(report) if report else None, "runs": summaries,
                                   "skipped": skipped,
                                   "plan": [c.summary() for c in comparisons]}  # fmt: skip
        if examples:
            payload.update(examples=worked_examples(), compiled_loop=compiled_loop(steps))
        print(json.dumps(payload))
    else:
        print(format_table(summaries))
        for line in warning_lines(summaries):
            print(line)
        for miss in skipped:
            print(f"not run: {miss['scenario']}, {miss['scheme']}: {miss['reason']}")
        for found in comparisons:
            print(f"\n{found.scenario}: against the global optimum (dynamic programming)")
            print(found.table())
            for line in found.lines():
                print(f"- {line}")
        if report is not None:
            print(f"\nreport: {report}")
    if after is not None:
        after(runs)
    if quiet or as_json:
        return 0
    print(f"({len(runs)} runs in {time.perf_counter() - started:.1f} s)")
    if examples:
        print("\nTextbook worked examples, computed now:")
        for ex in worked_examples():
            print(f"- {ex['example']}")
            for key, value in ex.items():
                if key != "example":
                    print(f"    {key}: {value}")
        print(f"\nA 1 kHz loop (Controller, compiled paths), first {steps} steps of the "
              "Panda circle; `redres bench` compares it with pink, mink and KDL:")  # fmt: skip
        for row in compiled_loop(steps):
            print(f"- {row['loop']}: {row['median_us']} µs per step, max position error "
                  f"{row['max_error_mm']} mm")  # fmt: skip
    return 0


def against_plan(spec: ScenarioSpec, logs: Sequence[RunLog], loud: bool) -> PlanComparison:
    """The scenario's runs against the global plan its ``[plan]`` table asks for."""
    settings = spec.plan
    assert settings is not None
    if loud:
        print(f"{spec.name}: planning the path globally ({settings.resolution} values per "
              f"sample, dt {settings.dt:g} s)", file=sys.stderr, flush=True)  # fmt: skip
    return compare_with_plan(
        spec, objective=settings.objective, resolution=settings.resolution,  # type: ignore[arg-type]
        parameter=settings.parameter, dt=settings.dt, clearance=settings.clearance,  # type: ignore[arg-type]
        qdd_max=settings.qdd_max, logs=logs,
    )  # fmt: skip


def run_demo(output: Output) -> int:
    """The flagship demo: every scheme on the built-in scenarios."""
    specs = [builtin(name) for name in DEMO_SCENARIOS]
    return run_scenarios(specs, output, title="redres demo", examples=True)
