"""Recount issue 18's reliability campaign (items 2–8, 10, 11): how many bad inputs give a
clear ``RedresError`` (or, for the command, one ``redres: error:`` line and exit 2), a raw
traceback, silent NaN/inf output, or a hang; and how many feasible hard-limit tasks near a
singularity (item 3) are met, with the scheme's ``feasible`` flag set.

    PYTHONPATH=src python benchmarks/reliability.py [--json] [--tasks N]

Runs on any checkout (point ``PYTHONPATH`` at another ``src`` to compare with main). The
command-line cases and the hang triggers of item 2 run in subprocesses with a time limit
(a hang in compiled code ignores Ctrl-C); the other library cases run in process.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
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
HANG_TIMEOUT = 60.0  # item 2's subprocesses: a step takes microseconds, an import seconds


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


_CHILD = """
import sys, warnings
import numpy as np
import redres as rr
from redres.errors import RedresError
from redres.resolution import QPScheme, SNSScheme, braking_velocity
warnings.simplefilter("ignore")
panda = rr.models.panda()
J = panda.jacobian(panda.neutral())
def wide_dh(limit):
    return rr.Robot.from_dh([dict(a=0.3, alpha=0, d=0, q_min=-limit, q_max=limit)] * 3)
try:
    value = np.asarray(getattr(CALL, "qd", CALL), dtype=float)
    print("RESULT", "ran" if np.isfinite(value).all() else "silent non-finite")
except RedresError:
    print("RESULT clear error")
except Exception as exc:
    print("RESULT raw", type(exc).__name__)
"""

#: Item 2: inputs that made the braking loop of the hard-limit box spin forever.
HANG_CASES = {
    "SNS step at q = 1e300": "SNSScheme(1e-3).step(panda, np.full(7, 1e300), J, np.zeros(6))",
    "QP step at q = 1e300": "QPScheme(1e-3).step(panda, np.full(7, 1e300), J, np.zeros(6))",
    "SNS step at q = 3e27": "SNSScheme(1e-3).step(panda, np.full(7, 3e27), J, np.zeros(6))",
    "braking_velocity(1e30, 1e-3, 1)": "braking_velocity(1e30, 1e-3, 1.0)",
    "braking_velocity(1, 1e-300, 1)": "braking_velocity(1.0, 1e-300, 1.0)",
    "braking_velocity(1, 1e-3, 1e-300)": "braking_velocity(1.0, 1e-3, 1e-300)",
    "braking_velocity(1, 1e-3, 5e-324)": "braking_velocity(1.0, 1e-3, 5e-324)",
    "SNSScheme(dt=1e-300) step": "SNSScheme(1e-300).step(panda, panda.neutral(), J, np.zeros(6))",
    "SNSScheme(qdd_max=1e-300) step": (
        "SNSScheme(1e-3, qdd_max=1e-300).step(panda, panda.neutral(), J, np.zeros(6))"
    ),
    "DH limits ±1e35, SNS step": (
        "SNSScheme(1e-3).step(wide_dh(1e35), np.zeros(3), np.eye(3)[:2], np.zeros(2))"
    ),
    "DH limits ±1e35, QP step": (
        "QPScheme(1e-3).step(wide_dh(1e35), np.zeros(3), np.eye(3)[:2], np.zeros(2))"
    ),
}


def run_child(code: str) -> str:
    """Item 2's case ``code`` in a fresh interpreter, killed after :data:`HANG_TIMEOUT`."""
    script = _CHILD.replace("CALL", f"({code})")
    try:
        proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                              timeout=HANG_TIMEOUT, check=False, env=os.environ)  # fmt: skip
    except subprocess.TimeoutExpired:
        return "hang"
    lines = [x for x in proc.stdout.splitlines() if x.startswith("RESULT ")]
    if not lines:
        return f"exit {proc.returncode} (no result)"
    return lines[-1].removeprefix("RESULT ")


def out_cases(tmp: Path) -> list[tuple[str, str]]:
    """Item 5: ``--out`` folders that hold a user's files. A case passes ("clear error")
    when the command refuses with one message and the user's file is intact; a stale
    staging folder of an earlier report must be cleaned ("ran")."""
    rows = []
    for i, user_file in enumerate(["report.html", "panda-joints.png", "notes.txt"]):
        folder = tmp / f"user{i}"
        folder.mkdir()
        (folder / user_file).write_text("the user's own file")
        result = run_cli(tmp, GOOD, str(folder))
        if (folder / user_file).read_text() != "the user's own file":
            result = "user's file replaced"
        rows.append((f"folder holding the user's {user_file}", result))
    cwd_before = sorted(os.listdir(Path.cwd()))
    result = run_cli(tmp, GOOD, "")
    if sorted(os.listdir(Path.cwd())) != cwd_before:
        result = "wrote into the current directory"
    rows.append(('--out ""', result))
    earlier = tmp / "earlier"
    earlier.mkdir()
    (earlier / ".redres-report").write_text("")
    (earlier / ".redres-staging-stale").mkdir()
    hours_ago = time.time() - 7200.0  # the writer cleans staging folders older than an hour
    os.utime(earlier / ".redres-staging-stale", (hours_ago, hours_ago))
    result = run_cli(tmp, GOOD, str(earlier))
    if (earlier / ".redres-staging-stale").exists():
        result = "stale staging folder left"
    rows.append(("earlier report with a stale staging folder (should run)", result))
    return rows


def scheme_cases() -> dict[str, Callable[[], Any]]:
    """Item 6: schemes, objectives and the controller handed bad ``q``/``xd``."""
    robot = rr.models.panda()
    q, J = robot.neutral(), robot.jacobian(robot.neutral())
    res, obj, tasks = rr.resolution, rr.objectives, rr.tasks
    nan_q, x0 = np.full(7, np.nan), np.zeros(6)
    makers: dict[str, Callable[[], Any]] = {
        "PriorityScheme": lambda: res.PriorityScheme([tasks.PostureTask()]),
        "GradientProjectionScheme": lambda: res.GradientProjectionScheme(
            [obj.JointLimitObjective()]
        ),
        "WeightedLeastNormScheme": res.WeightedLeastNormScheme,
        "AugmentedJacobianScheme": lambda: res.AugmentedJacobianScheme([tasks.PostureTask()]),
    }
    cases: dict[str, Callable[[], Any]] = {}
    for name, make in makers.items():
        bad = {
            "xd = None": (q, None),
            "xd = NaN": (q, np.full(6, np.nan)),
            "xd = inf": (q, np.full(6, np.inf)),
            "q = NaN": (nan_q, x0),
            "q of shape (5,)": (np.zeros(5), x0),
            "xd of shape (4,)": (q, np.zeros(4)),
        }
        for label, (qq, xx) in bad.items():
            cases[f"{name}.step, {label}"] = lambda make=make, qq=qq, xx=xx: make().step(
                robot, qq, J, xx
            )
    cases["JointLimitObjective.gradient(q = NaN)"] = lambda: obj.JointLimitObjective().gradient(
        robot, nan_q
    )
    T = robot.fk(q)
    far = T.copy()
    far[:3, 3] = 1e300

    def overflowing_twist() -> Any:
        task = tasks.FrameTask()
        task.set_target(far)
        return rr.control.Controller(robot, task, res.PseudoInverseScheme(), gain=1e300).step(q)

    cases["Controller.step, overflowing twist"] = overflowing_twist
    return cases


def feasible_tasks(count: int, seed: int = 18) -> list[tuple[str, str, str]]:
    """Item 3: ``count`` tasks per scheme near a singularity (σ_min of 1e-12 to 1e-6, Panda
    and planar 3R), feasible by construction (``ẋ = J q̇*`` with ``q̇*`` drawn in the box),
    plus the issue's planar 3R reproduction. "met": ``‖J q̇ − ẋ‖ ≤ 1e-9 max(1, ‖ẋ‖)`` and
    ``feasible``; "met, flag false"; "missed"."""
    rng = np.random.default_rng(seed)
    robots = [rr.models.panda(), rr.models.planar([1.0, 1.0, 1.0])]
    rows = []
    folded = (np.array([np.pi, -np.pi, np.pi - 1e-9]), [0.0073213, -0.0147677, -0.0257017],
              np.array([2.53e-11, 0.0256468, -0.0253003]))  # fmt: skip
    planar = robots[1]
    J = planar.jacobian(folded[0])[[0, 1, 5]]
    sns = rr.resolution.SNSScheme(1e-3, qd_max=3, qdd_max=20)
    sns.qd_prev = np.array(folded[1])
    rows.append(("SNS", "the issue's folded planar 3R", _met(sns, planar, folded[0], J, folded[2])))
    for i in range(count):
        robot = robots[i % 2]
        q = robot.q_min + rng.uniform(0.05, 0.95, robot.n) * (robot.q_max - robot.q_min)
        J = robot.jacobian(q)
        J = J[[0, 1, 5]] if robot.n == 3 else J
        U, s, Vt = np.linalg.svd(J, full_matrices=False)
        s[-1] = 10.0 ** rng.uniform(-12, -6)
        J = (U * s) @ Vt
        prev = rng.uniform(-0.5, 0.5, robot.n) * robot.qd_max
        for make in (rr.resolution.QPScheme, rr.resolution.SNSScheme):
            scheme = make(1e-3)
            scheme.qd_prev = prev.copy()
            lo, hi = scheme.step(robot, q, J, np.zeros(J.shape[0])).details.bounds
            xd = J @ (lo + rng.uniform(0.0, 1.0, robot.n) * (hi - lo))
            scheme.qd_prev = prev.copy()
            rows.append((make.name.upper(), f"{robot.n}-joint, σ_min {s[-1]:.0e}",
                         _met(scheme, robot, q, J, xd)))  # fmt: skip
    return rows


def _met(scheme: Any, robot: rr.Robot, q: Any, J: Any, xd: Any) -> str:
    result = scheme.step(robot, q, J, xd)
    ok = np.linalg.norm(J @ result.qd - xd) <= 1e-9 * max(1.0, float(np.linalg.norm(xd)))
    if ok:
        return "met" if result.feasible else "met, flag false"
    return "missed, flag true" if result.feasible else "missed"


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
    parser.add_argument("--tasks", type=int, default=400, help="item 3's tasks per scheme")
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
        for name, code in HANG_CASES.items():
            rows.append(("hang triggers (item 2)", name, run_child(code)))
        for name, result in out_cases(tmp):
            rows.append(("--out (item 5)", name, result))
        for name, call in scheme_cases().items():
            rows.append(("scheme input (item 6)", name, classify(call)))
    tasks = feasible_tasks(args.tasks)
    counts = Counter(result for _, _, result in rows)
    met = {s: Counter(r for g, _, r in tasks if g == s) for s in ("QP", "SNS")}
    if args.json:
        print(json.dumps({"counts": counts, "cases": rows, "feasible tasks": met}))
        return 0
    for group, name, result in rows:
        print(f"{group:26s} {name:50s} {result}")
    print(f"\n{len(rows)} inputs:", ", ".join(f"{n} {k}" for k, n in counts.most_common()))
    for group in dict.fromkeys(g for g, _, _ in rows):
        sub = Counter(r for g, _, r in rows if g == group)
        print(f"  {group}: " + ", ".join(f"{n} {k}" for k, n in sub.most_common()))
    for scheme, tally in met.items():
        told = ", ".join(f"{n} {k}" for k, n in tally.most_common())
        print(f"feasible tasks near a singularity (item 3), {scheme}: {told}")
    for scheme, name, result in tasks:
        if result != "met":
            print(f"  {scheme} {name}: {result}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
