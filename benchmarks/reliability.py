"""Recount issue 18's reliability campaign for the cases this branch fixed (items 4, 7, 8, 10,
11): how many bad inputs give a clear ``RedresError`` (or, for the command, one
``redres: error:`` line and exit 2), a raw traceback, silent NaN/inf output, or a hang.

    PYTHONPATH=src python benchmarks/reliability.py [--json]

Runs on any checkout (point ``PYTHONPATH`` at another ``src`` to compare with main). The
command-line cases run in subprocesses with a time limit; the library cases in process.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import redres as rr
from redres.errors import RedresError

GOOD = """name = "tiny"
[robot]
model = "panda"
[trajectory]
type = "circle"
radius = 0.05
period = 1.0
[run]
dt = 0.002
duration = 0.02
[[schemes]]
type = "pinv"
"""
TIMEOUT = 120.0


def cli_cases(tmp: Path) -> dict[str, tuple[str, str]]:
    """Name -> (scenario text, --out folder) of item 4's command-line cases."""
    (tmp / "afile").write_text("x")
    (tmp / "html" / "report.html").mkdir(parents=True)
    (tmp / "html2" / "report.html").mkdir(parents=True)
    (tmp / "html2" / ".redres-report").write_text("")
    out = str(tmp / "report")
    sphere = '\n[[obstacles]]\ntype = "sphere"\ncenter = [0.4, 0, 0.5]\nradius = 1e300\n'
    posture = 'type = "gradient_projection"\nobjectives = [{ type = "posture", weights = [-1, 1, 1, 1, 1, 1, 1] }]'  # noqa: E501
    edits = {
        "zero steps": GOOD.replace("duration = 0.02", "duration = 0.0005"),
        "nested 3000 deep": GOOD + "x = " + "[" * 3000 + "]" * 3000 + "\n",
        "400-digit integer": GOOD.replace("duration = 0.02", "duration = " + "9" * 400),
        "400-digit integer in a vector": GOOD.replace(
            "period = 1.0", "period = 1.0\nnormal = [0, 0, " + "7" * 400 + "]"
        ),
        "dt = 1e-300": GOOD.replace("dt = 0.002", "dt = 1e-300"),
        "dt = 5e-324": GOOD.replace("dt = 0.002", "dt = 5e-324"),
        "duration = 1e9": GOOD.replace("duration = 0.02", "duration = 1e9"),
        "obstacle radius 1e300": GOOD + sphere,
        "5000-character urdf path": GOOD.replace('model = "panda"', f'urdf = "{"a" * 5000}"'),
        "negative posture weights": GOOD.replace('type = "pinv"', posture),
        "figure eight, zero normal": GOOD.replace(
            'type = "circle"\nradius = 0.05', 'type = "figure_eight"\nwidth = 0.1\nheight = 0.1'
        ).replace("period = 1.0", "period = 1.0\nnormal = [0, 0, 0]"),
    }
    cases = {name: (text, out) for name, text in edits.items()}
    cases |= {
        "--out under a file": (GOOD, str(tmp / "afile" / "sub")),
        "--out in /proc": (GOOD, "/proc/redres-report"),
        "--out 5000 characters": (GOOD, str(tmp / ("b" * 5000))),
        "report.html folder in --out": (GOOD, str(tmp / "html")),
        "report.html folder in an earlier report": (GOOD, str(tmp / "html2")),
    }
    return cases


def run_cli(tmp: Path, text: str, out: str, bom: bool = False) -> str:
    path = tmp / "scenario.toml"
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode())
    try:
        proc = subprocess.run(
            [sys.executable, "-m", "redres", "run", str(path), "--quiet", "--out", out],
            capture_output=True, text=True, timeout=TIMEOUT, check=False, env=os.environ,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        return "hang"
    if "Traceback" in proc.stderr:
        return "raw traceback"
    errors = [x for x in proc.stderr.splitlines() if x.startswith("redres: error:")]
    if proc.returncode == 2 and len(errors) == 1:
        return "clear error"
    return "ran" if proc.returncode == 0 else f"exit {proc.returncode}"


def library_cases(tmp: Path) -> dict[str, Callable[[], Any]]:
    """Name -> call of the library cases (items 7, 8, 10, 11)."""
    urdf = (Path(__file__).parents[1] / "tests" / "robot" / "test_urdf.py").read_text()
    two_link = urdf.split('TWO_LINK = """', 1)[1].split('"""', 1)[0].format(kind="revolute")

    def from_urdf(old: str, new: str, **kwargs: Any) -> Callable[[], Any]:
        def call() -> Any:
            path = tmp / "r.urdf"
            path.write_text(two_link.replace(old, new, 1))
            return rr.Robot.from_urdf(path, **kwargs).mass_matrix(np.zeros(2))

        return call

    def snake() -> Any:
        body = ['<robot name="s"><link name="l0"/>'] + [
            f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
            '<axis xyz="0 1 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>'
            f'<link name="l{i}"/>'
            for i in range(1, 2001)
        ]
        (tmp / "snake.urdf").write_text("".join(body) + "</robot>")
        return rr.Robot.from_urdf(tmp / "snake.urdf")

    panda, planar = rr.models.panda(), rr.models.planar([1.0, 1.0])
    prismatic = [dict(a=0, alpha=0, d=0, theta=4, joint="prismatic")]
    eye = np.eye(4)
    cases: dict[str, Callable[[], Any]] = {
        "urdf mass -1": from_urdf('<mass value="1"/>', '<mass value="-1"/>'),
        "urdf mass nan": from_urdf('<mass value="1"/>', '<mass value="nan"/>'),
        "urdf axis 0 0 0": from_urdf('<axis xyz="0 1 0"/>', '<axis xyz="0 0 0"/>'),
        "urdf tip = root link": from_urdf("", "", tip="base"),
        "urdf of 2000 joints": snake,
        "dh of 101 joints": lambda: rr.Robot.from_dh([dict(a=0.01, alpha=0, d=0)] * 101),
        "dh name = 5": lambda: rr.Robot.from_dh([dict(a=0, alpha=0, d=0, name=5)]),
        "dh a = 10**400": lambda: rr.Robot.from_dh([dict(a=10**400, alpha=0, d=0)]),
        "random_configuration, inf limits": lambda: rr.Robot.from_dh(
            prismatic
        ).random_configuration(0),
        "random_configuration margin=-1": lambda: _inside(
            planar, planar.random_configuration(0, margin=-1.0)
        ),
        "random_configuration rng='x'": lambda: planar.random_configuration("x"),  # type: ignore[arg-type]
        "add_frame(name=5)": lambda: planar.add_frame(5, "tool", eye),  # type: ignore[arg-type]
        "PostureObjective(weights=-1)": lambda: rr.objectives.PostureObjective(weights=[-1.0] * 7),
        "PostureObjective(q_ref of 2)": lambda: rr.objectives.PostureObjective([0.0, 1.0]).gradient(
            panda, panda.neutral()
        ),
        "FigureEight(normal=0)": lambda: (
            rr.control.FigureEight(eye, 0.1, 0.1, 1.0, normal=(0, 0, 0)).sample(0.1).pose
        ),
        "as_scalar(10**400)": lambda: rr.run(
            panda,
            rr.tasks.FrameTask(),
            None,
            rr.resolution.PseudoInverseScheme(),
            duration=10**400,
        ),
        "rr.run dt = 1e-300": lambda: rr.run(
            panda,
            rr.tasks.FrameTask(),
            None,
            rr.resolution.PseudoInverseScheme(),
            dt=1e-300,
            duration=1.0,
        ),
    }
    return cases


def _inside(robot: rr.Robot, q: np.ndarray) -> np.ndarray:
    """``q`` if inside the limits, else NaN (a silently wrong answer counts as non-finite)."""
    return q if robot.within_limits(q) else np.full_like(q, np.nan)


def complex_cases() -> dict[str, Callable[[], Any]]:
    """Item 10: the public array entry points, each handed one complex array."""
    robot = rr.models.panda()
    q, J, M = robot.neutral(), robot.jacobian(robot.neutral()), robot.mass_matrix(robot.neutral())
    z, qz, Jz, xz = 0.5j, robot.neutral() + 0.5j, J + 0.5j, np.zeros(6) + 0.5j
    res, obj, tasks, ctl = rr.resolution, rr.objectives, rr.tasks, rr.control
    T = robot.fk(q)
    schemes = {
        "PseudoInverseScheme": res.PseudoInverseScheme,
        "GradientProjectionScheme": lambda: res.GradientProjectionScheme(
            [obj.JointLimitObjective()]
        ),
        "WeightedLeastNormScheme": res.WeightedLeastNormScheme,
        "AugmentedJacobianScheme": res.AugmentedJacobianScheme,
        "PriorityScheme": lambda: res.PriorityScheme([tasks.PostureTask()]),
        "SNSScheme": lambda: res.SNSScheme(1e-3),
        "QPScheme": lambda: res.QPScheme(1e-3),
    }
    cases: dict[str, Callable[[], Any]] = {
        "Robot.fk(q)": lambda: robot.fk(qz),
        "Robot.jacobian(q)": lambda: robot.jacobian(qz),
        "Robot.kinematics(q)": lambda: robot.kinematics(qz),
        "Robot.jacobian_dot(q)": lambda: robot.jacobian_dot(qz, q),
        "Robot.jacobian_dot(qd)": lambda: robot.jacobian_dot(q, qz),
        "Robot.jacobian_derivatives(q)": lambda: robot.jacobian_derivatives(qz),
        "Robot.point_jacobians(q)": lambda: robot.point_jacobians(qz, ["tcp"]),
        "Robot.mass_matrix(q)": lambda: robot.mass_matrix(qz),
        "Robot.bias(q)": lambda: robot.bias(qz, q),
        "Robot.bias(qd)": lambda: robot.bias(q, qz),
        "Robot.gravity(q)": lambda: robot.gravity(qz),
        "Robot.inverse_dynamics(qdd)": lambda: robot.inverse_dynamics(q, q, qz),
        "Robot.forward_dynamics(tau)": lambda: robot.forward_dynamics(q, q, qz),
        "Robot.joint_limit_margin(q)": lambda: robot.joint_limit_margin(qz),
        "Robot.within_limits(q)": lambda: robot.within_limits(qz),
        "Robot.add_frame(T)": lambda: robot.add_frame("x", "tcp", np.eye(4) + 0j),
        "Robot.from_dh(base)": lambda: rr.Robot.from_dh([dict(a=1, alpha=0, d=0)], base=T + z),
        "linalg.pinv": lambda: rr.linalg.pinv(Jz),
        "linalg.right_pinv": lambda: rr.linalg.right_pinv(Jz),
        "linalg.left_pinv": lambda: rr.linalg.left_pinv(Jz.T),
        "linalg.damped_pinv": lambda: rr.linalg.damped_pinv(Jz, 0.1),
        "linalg.damped_pinv(damping)": lambda: rr.linalg.damped_pinv(J, 0.1 + z),
        "linalg.adaptive_damped_pinv": lambda: rr.linalg.adaptive_damped_pinv(Jz, 0.1, 0.05),
        "linalg.weighted_pinv(J)": lambda: rr.linalg.weighted_pinv(Jz, np.eye(7)),
        "linalg.weighted_pinv(W)": lambda: rr.linalg.weighted_pinv(J, np.eye(7) + z),
        "linalg.generalized_inverse": lambda: rr.linalg.generalized_inverse(Jz),
        "linalg.square_inverse": lambda: rr.linalg.square_inverse(M + z),
        "linalg.nullspace_projector": lambda: rr.linalg.nullspace_projector(Jz),
        "linalg.nullspace_basis": lambda: rr.linalg.nullspace_basis(Jz),
        "linalg.manipulability": lambda: rr.linalg.manipulability(Jz),
        "linalg.singular_values": lambda: rr.linalg.singular_values(Jz),
        "linalg.sigma_min": lambda: rr.linalg.sigma_min(Jz),
        "linalg.condition_number": lambda: rr.linalg.condition_number(Jz),
        "linalg.task_space_inertia(J)": lambda: rr.linalg.task_space_inertia(Jz, M),
        "linalg.task_space_inertia(M)": lambda: rr.linalg.task_space_inertia(J, M + z),
        "linalg.dynamically_consistent_pinv": lambda: rr.linalg.dynamically_consistent_pinv(Jz, M),
        "linalg.dynamically_consistent_projector": lambda: (
            rr.linalg.dynamically_consistent_projector(Jz, M)
        ),
        "linalg.rate_step(J)": lambda: rr.linalg.rate_step(Jz, np.zeros(6)).qd,
        "linalg.rate_step(xd)": lambda: rr.linalg.rate_step(J, xz).qd,
        "linalg.moore_penrose_residuals": lambda: rr.linalg.moore_penrose_residuals(
            Jz, np.linalg.pinv(J)
        ),
        "JointLimitObjective.gradient(q)": lambda: obj.JointLimitObjective().gradient(robot, qz),
        "PostureObjective.gradient(q)": lambda: obj.PostureObjective().gradient(robot, qz),
        "ManipulabilityObjective.gradient(q)": lambda: obj.ManipulabilityObjective().gradient(
            robot, qz
        ),
        "PostureObjective(q_ref)": lambda: obj.PostureObjective(qz),
        "PostureObjective(weights)": lambda: obj.PostureObjective(weights=qz),
        "SphereObstacle(center)": lambda: obj.SphereObstacle(np.zeros(3) + z),
        "CapsuleObstacle(a)": lambda: obj.CapsuleObstacle(np.zeros(3) + z, np.ones(3)),
        "FrameTask.set_target(pose)": lambda: tasks.FrameTask().set_target(T + z),
        "PostureTask(q_ref)": lambda: tasks.PostureTask(qz),
        "LookAtTask(target)": lambda: tasks.LookAtTask(target=np.ones(3) + z),
        "ArmAngleTask(reference)": lambda: tasks.ArmAngleTask(reference=np.ones(3) + z),
        "Circle(start)": lambda: ctl.Circle(T + z, 0.1, 1.0),
        "Circle(normal)": lambda: ctl.Circle(T, 0.1, 1.0, normal=np.ones(3) + z),
        "FigureEight(normal)": lambda: ctl.FigureEight(T, 0.1, 0.1, 1.0, normal=np.ones(3) + z),
        "Line(end)": lambda: ctl.Line(T, np.ones(3) + z, 1.0),
        "Hold(start)": lambda: ctl.Hold(T + z, 1.0),
        "Controller.step(q)": lambda: ctl.Controller(
            robot, tasks.FrameTask(), res.PseudoInverseScheme()
        ).step(qz),
        "rr.run(q0)": lambda: rr.run(
            robot, tasks.FrameTask(), ctl.Hold(T, 0.01), res.PseudoInverseScheme(), q0=qz
        ),
        "rr.ik(q0)": lambda: rr.ik(robot, T, q0=qz),
    }
    for name, make in schemes.items():
        cases[f"{name}.step(q)"] = lambda make=make: make().step(robot, qz, J, np.zeros(6))
        cases[f"{name}.step(J)"] = lambda make=make: make().step(robot, q, Jz, np.zeros(6))
        cases[f"{name}.step(xd)"] = lambda make=make: make().step(robot, q, J, xz)
    return cases


def classify(call: Callable[[], Any], expect_error: bool = True) -> str:
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            value = call()
        except RedresError:
            return "clear error"
        except Exception as exc:  # counting them is the point
            return f"raw {type(exc).__name__}"
    if not _finite(value):
        return "silent non-finite"
    return "silently accepted" if expect_error else "ran"


def _finite(value: Any) -> bool:
    for item in value if isinstance(value, tuple) else (value,):
        try:
            arr = np.asarray(getattr(item, "qd", item), dtype=float)
        except (TypeError, ValueError):
            continue
        if not np.isfinite(arr).all():
            return False
    return True


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    rows: list[tuple[str, str, str]] = []
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        for name, (text, out) in cli_cases(tmp).items():
            rows.append(("command (item 4, 11)", name, run_cli(tmp, text, out)))
        rows.append(("command (item 11)", "UTF-8 BOM (should run)",
                     run_cli(tmp, GOOD, str(tmp / "bom"), bom=True)))  # fmt: skip
        for name, call in library_cases(tmp).items():
            rows.append(("library (items 7, 8, 11)", name, classify(call)))
        ok = [dict(a=0, alpha=0, d=0, theta=4, joint="prismatic")]
        builds = classify(lambda: rr.Robot.from_dh(ok).fk([0.3]), expect_error=False)
        rows.append(
            ("library (item 8)", "prismatic DH joint without limits (should build)", builds)
        )
        for name, call in complex_cases().items():
            rows.append(("complex input (item 10)", name, classify(call)))
    counts = Counter(result for _, _, result in rows)
    if args.json:
        print(json.dumps({"counts": counts, "cases": rows}))
        return 0
    for group, name, result in rows:
        print(f"{group:26s} {name:50s} {result}")
    print(f"\n{len(rows)} inputs:", ", ".join(f"{n} {k}" for k, n in counts.most_common()))
    for group in dict.fromkeys(g for g, _, _ in rows):
        sub = Counter(r for g, _, r in rows if g == group)
        print(f"  {group}: " + ", ".join(f"{n} {k}" for k, n in sub.most_common()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
