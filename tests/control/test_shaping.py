"""Command shaping: the shaped stream keeps velocity, acceleration and jerk limits as a
robot checks them (finite differences at the control period), judged by a checker
written from that definition (redres.testing), not from the shaper."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

import redres as rr
from redres import _compile
from redres.control.shaping import CommandShaper
from redres.testing import command_violations

DT = 1e-3
#: The Panda's published joint limits (Franka, "Robot and interface specifications").
V = np.array([2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61])
A = np.array([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0])
J = np.array([7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0])


def violations(
    stream: np.ndarray, qd0: np.ndarray, qdd0: np.ndarray, limits: tuple[np.ndarray, ...]
) -> list[tuple[int, str, int, float]]:
    """``(cycle, quantity, joint, value / limit)`` of every command of ``stream`` over a
    limit (:func:`redres.testing.command_violations`, which shares no code with the
    shaper)."""
    return [tuple(v) for v in command_violations(stream, DT, limits, qd0, qdd0)]  # type: ignore[misc]


def test_the_checker_flags_a_jump_and_passes_a_smooth_ramp() -> None:
    """The checker itself: a velocity step of 0.13 rad/s in one cycle is 130 rad/s² and
    130,000 rad/s³; a ramp at 1 rad/s² after a jerk-limited start is none."""
    step = np.full((3, 7), 0.13)
    found = violations(step, np.zeros(7), np.zeros(7), (V, A, J))
    assert {(k, name) for k, name, _, _ in found} == {(0, "acceleration"), (0, "jerk"), (1, "jerk")}
    ramp = np.cumsum(np.full((50, 7), 1.0 * DT), axis=0)  # a = 1 from the first cycle
    assert violations(ramp, np.zeros(7), np.full(7, 1.0), (V, A, J)) == []


def test_random_targets_never_break_a_limit(rng: np.random.Generator) -> None:
    """Wanted velocities jumping anywhere in ±1.5 v_max, from random measured states that
    keep the limits: every shaped command within the Panda's limits."""
    shaper = CommandShaper(V, A, J, DT)
    for _ in range(20):
        qd0 = rng.uniform(-0.5, 0.5, 7) * V
        shaper.reset(qd0)
        wanted = rng.uniform(-1.5, 1.5, (400, 7)) * V
        wanted = np.repeat(wanted[::40], 40, axis=0) + 0.05 * rng.standard_normal((400, 7))
        stream = np.array([shaper(u) for u in wanted])
        assert violations(stream, qd0, np.zeros(7), (V, A, J)) == []


def test_a_feasible_command_passes_unchanged() -> None:
    """A wanted stream that keeps the limits (a slow sine) is the shaped stream, exactly
    after the first cycles."""
    shaper = CommandShaper(V, A, J, DT)
    t = np.arange(1000) * DT
    wanted = 0.3 * np.sin(2 * np.pi * 0.5 * t)[:, None] * np.ones(7)
    stream = np.array([shaper(u) for u in wanted])
    np.testing.assert_array_equal(stream, wanted)


@pytest.mark.parametrize("change", [0.001, 0.05, 0.5, 2.0])
def test_a_velocity_step_takes_the_time_optimal_number_of_cycles(change: float) -> None:
    """From rest to a velocity ``Δv``, jerk and acceleration limited: the continuous-time
    minimum is ``2√(Δv/J)`` when the acceleration limit is not reached (``Δv < A²/J``),
    else ``Δv/A + A/J``. The shaper lands in that time to within two cycles, exactly, and
    without overshoot."""
    a_max, j_max = 10.0, 5000.0
    shaper = CommandShaper(np.inf, a_max, j_max, DT, margin=0.0, n=1)
    stream = np.array([shaper(np.array([change]))[0] for _ in range(500)])
    landed = int(np.argmax(stream == change)) + 1
    assert stream[landed - 1] == change and np.all(stream[landed - 1 :] == change)
    assert np.all(np.diff(stream) >= 0.0) and stream.max() == change  # no overshoot
    optimal = 2 * math.sqrt(change / j_max) if change < a_max**2 / j_max else (
        change / a_max + a_max / j_max)  # fmt: skip
    assert optimal / DT - 1 <= landed <= optimal / DT + 2


def test_limits_are_aimed_inside_by_the_margin() -> None:
    """A saturated stream, each joint on its own, peaks at (1 − margin) of each limit."""
    shaper = CommandShaper(V, A, J, DT, synchronized=False)
    stream = np.array([shaper(np.full(7, 10.0)) for _ in range(1000)])
    a = np.diff(np.vstack([np.zeros(7), stream]), axis=0) / DT
    np.testing.assert_allclose(np.abs(stream).max(axis=0), V * (1 - 1e-3), rtol=1e-12)
    np.testing.assert_allclose(np.abs(a).max(axis=0), A * (1 - 1e-3), rtol=1e-9)


def test_synchronised_joints_keep_the_direction_of_the_wanted_velocity(
    rng: np.random.Generator,
) -> None:
    """From rest to a constant wanted velocity, synchronised: every shaped velocity is a
    multiple of the wanted one (the task velocity keeps its direction) but in the few
    cycles where a jerk limit makes a joint keep more acceleration than its share (0.04 %
    of the speed here); each joint on its own, the direction bends by 5 % and more."""
    u = rng.uniform(-1.0, 1.0, 7) * V
    unit = u / np.linalg.norm(u)
    for synchronized in (True, False):
        shaper = CommandShaper(V, A, J, DT, synchronized=synchronized)
        stream = np.array([shaper(u) for _ in range(400)])
        off_line = np.linalg.norm(stream - np.outer(stream @ unit, unit), axis=1)
        np.testing.assert_array_equal(stream[-1], u)
        if synchronized:
            assert off_line.max() <= 1e-3 * np.linalg.norm(u)
            assert np.median(off_line) <= 1e-12 * np.linalg.norm(u)
        else:
            assert off_line.max() > 0.05 * np.linalg.norm(u)


def test_the_plain_twin_shapes_as_the_compiled_kernel(rng: np.random.Generator) -> None:
    twin = _compile.groups()["shaping"].module(plain=True)
    assert not _compile.is_compiled(twin)
    shaper = CommandShaper(V, A, J, DT)
    state = np.zeros((2, 7))
    out = np.empty(7)
    for u in rng.uniform(-3, 3, (200, 7)):
        expected = shaper(u)
        assert twin.shape(u, shaper._aim, DT, True, state, out)
        np.testing.assert_allclose(out, expected, rtol=0, atol=1e-15)


def test_bad_input_is_refused_by_name() -> None:
    with pytest.raises(rr.errors.InvalidParameterError, match="qdd_max must be positive"):
        CommandShaper(V, -A, J)
    with pytest.raises(rr.errors.InvalidParameterError, match="nothing to shape"):
        CommandShaper(V, np.inf, np.inf, n=7)
    with pytest.raises(rr.errors.ShapeError, match="different lengths"):
        CommandShaper(V, A[:6], J)
    with pytest.raises(rr.errors.InvalidParameterError, match="number of joints"):
        CommandShaper(1.0, 1.0, 1.0)
    with pytest.raises(rr.errors.ShapeError, match=r"qddd_max must be a number or shape \(7,\)"):
        CommandShaper(V, A, J.reshape(7, 1))
    shaper = CommandShaper(V, A, J)
    with pytest.raises(rr.errors.ShapeError, match=r"shape \(7,\)"):
        shaper(np.zeros(6))
    with pytest.raises(rr.errors.NonFiniteError, match="finite"):
        shaper(np.full(7, np.nan))
    with pytest.raises(rr.errors.InvalidParameterError, match="qd"):
        shaper(np.full(7, 1j))  # complex: refused by name, never made real
    assert np.all(shaper.qd == 0.0)  # a refused command leaves the state


def random_run(seed: int, spec: Any, shaping: bool, duration: float = 0.25) -> rr.control.RunLog:
    """Random run ``seed`` of the Panda: the built-in joint-limit-circle scenario's start
    and circle, or a random start and a circle of 1–10 cm at 2–6 s a turn with a 0–0.5 s
    ramp; one of the scenario's kinematic schemes; a gain of 10–100/s; the robot started
    1–5 mrad per joint away from where the trajectory starts. (benchmarks/shaping.py
    measures what shaping costs on these runs.)"""
    rng = np.random.default_rng(seed)
    robot = spec.robot
    if rng.random() < 0.5:
        q_ref, trajectory = spec.q0, spec.trajectory
    else:
        q_ref = robot.random_configuration(rng, margin=0.3)
        trajectory = rr.control.Circle(
            robot.fk(q_ref), rng.uniform(0.01, 0.1), rng.uniform(2.0, 6.0),
            normal=rng.standard_normal(3), phase=rng.uniform(0, 2 * np.pi),
            ramp=rng.uniform(0.0, 0.5),
        )  # fmt: skip
    kinematic = [s for s in spec.schemes if s.kind != "osc"]
    scheme = kinematic[rng.integers(len(kinematic))].build()
    offset = rng.uniform(1e-3, 5e-3, robot.n) * rng.choice([-1.0, 1.0], robot.n)
    q0 = np.clip(q_ref + offset, robot.q_min, robot.q_max)
    gain = float(rng.uniform(10.0, 100.0))
    return rr.run(robot, rr.tasks.FrameTask(), trajectory, scheme, q0=q0, gain=gain,
                  duration=duration, shaping=shaping, progress=False)  # fmt: skip


def test_two_hundred_runs_keep_the_pandas_limits_only_when_shaped() -> None:
    """Built-in scenario and random runs of the Panda, random gains, starts up to 5 mrad
    off: every shaped command stream keeps the published per-cycle limits at 1 kHz; the
    same runs unshaped break one at the first cycle."""
    from redres.scenarios.spec import builtin

    spec = builtin("panda_joint_limit_circle")
    limits = (V, A, J)
    rest = np.zeros(7)
    for seed in range(200):
        shaped = random_run(seed, spec, True)
        assert violations(shaped.qd, rest, rest, limits) == [], f"run {seed}"
        plain = random_run(seed, spec, False)
        found = violations(plain.qd, rest, rest, limits)
        assert found and found[0][0] == 0, f"run {seed}: {found[:1]}"


@pytest.mark.parametrize("scheme", ["fused", "frame", "composed"])
def test_every_controller_path_ends_in_the_shaper(scheme: str) -> None:
    """On each path the applied velocity is the shaper's output for the controller's own
    (``qd_wanted``), and the next configuration integrates it; without shaping the two
    are the same velocity."""
    from redres.objectives import JointLimitObjective
    from redres.resolution import GradientProjectionScheme, SNSScheme
    from redres.tasks import FrameTask, PostureTask

    robot = rr.models.panda()
    task: rr.tasks.Task = FrameTask()
    made = GradientProjectionScheme([JointLimitObjective()]) if scheme == "fused" else SNSScheme()
    if scheme == "composed":
        task = PostureTask(robot.neutral() + 0.1)
    else:  # a target 5 mm off
        target = robot.fk(robot.neutral())
        target[:3, 3] += 0.005
        task.set_target(target)  # type: ignore[attr-defined]
    controller = rr.Controller(robot, task, made, shaping=True)
    twin = CommandShaper.for_robot(robot, DT)
    q, shaped = robot.neutral(), 0
    for _ in range(20):
        q_next = controller.step(q)
        expected = twin(controller.qd_wanted)
        np.testing.assert_array_equal(controller.qd, expected)
        np.testing.assert_allclose(q_next, q + expected * DT, rtol=0, atol=1e-15)
        shaped += bool(np.any(controller.qd != controller.qd_wanted))
        q = q_next
    assert controller.path == scheme
    assert shaped >= 5  # it did shape
    plain = rr.Controller(robot, FrameTask(), GradientProjectionScheme([JointLimitObjective()]))
    plain.step(robot.neutral())
    assert plain.shaper is None and np.array_equal(plain.qd, plain.qd_wanted)


def test_a_shaper_must_fit_the_controller() -> None:
    from redres.resolution import PseudoInverseScheme
    from redres.tasks import FrameTask

    robot = rr.models.panda()
    for shaper in (CommandShaper(V, A, J, dt=2e-3), CommandShaper(1.0, 1.0, 1.0, n=6)):
        with pytest.raises(rr.errors.InvalidParameterError, match="the shaper is for"):
            rr.Controller(robot, FrameTask(), PseudoInverseScheme(), shaping=shaper)
    with pytest.raises(rr.errors.InvalidParameterError, match="shaping must be True, False"):
        rr.Controller(robot, FrameTask(), PseudoInverseScheme(), shaping="yes")  # type: ignore[arg-type]
    with pytest.raises(rr.errors.InvalidParameterError, match="nothing to shape"):
        rr.Controller(rr.models.planar(), FrameTask(), PseudoInverseScheme(), shaping=True)
