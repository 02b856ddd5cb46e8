"""The compiled dynamics of a serial chain against Pinocchio (the oracle), and the compiled
operational-space step against the controller's Pinocchio path, on every built-in arm, the
URDF fixture, DH chains with prismatic joints and armature, and payloads."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.dynamics import OperationalSpaceController, with_payload
from redres.dynamics.chain import ChainDynamics, chain_dynamics
from redres.errors import NonFiniteError, ShapeError
from redres.linalg import AdaptiveDamping
from redres.objectives import JointLimitObjective, ManipulabilityObjective, PostureObjective
from redres.robot.chain import NotSerialChainError
from redres.tasks import FrameTask, PositionTask


def _states(robot: rr.Robot, rng: np.random.Generator, count: int):
    lo = np.where(np.isfinite(robot.q_min), robot.q_min, -np.pi)
    hi = np.where(np.isfinite(robot.q_max), robot.q_max, np.pi)
    for _ in range(count):
        yield rng.uniform(lo, hi), rng.uniform(-3.0, 3.0, robot.n)


def _check_terms(robot: rr.Robot, rng: np.random.Generator, count: int) -> None:
    dyn = ChainDynamics(robot)
    worst = dict.fromkeys(("pose", "jacobian", "jdot_qd", "mass_matrix", "bias"), 0.0)
    for q, qd in _states(robot, rng, count):
        got = dyn.terms(q, qd)
        M = robot.mass_matrix(q)
        want = {
            "pose": robot.fk(q),
            "jacobian": robot.jacobian(q),
            "jdot_qd": robot.jacobian_dot(q, qd) @ qd,
            "mass_matrix": M,
            "bias": robot.bias(q, qd),
        }
        for name, value in want.items():
            scale = max(1.0, float(np.abs(value).max()))
            worst[name] = max(worst[name], float(np.abs(getattr(got, name) - value).max()) / scale)
    assert max(worst.values()) < 1e-12, worst


@pytest.mark.parametrize("name", ["panda", "iiwa14", "srs7", "planar3"])
def test_builtin_arms_equal_pinocchio_on_10000_states(name: str) -> None:
    robot = rr.models.load(name)
    _check_terms(robot, np.random.default_rng(7), 10_000 if name in ("panda", "iiwa14") else 2_000)


def test_urdf_fixture_and_a_payload_equal_pinocchio(fixtures_dir: Path) -> None:
    robot = rr.Robot.from_urdf(fixtures_dir / "panda_description.urdf", tip="panda_hand_tcp")
    _check_terms(robot, np.random.default_rng(1), 500)
    load = rr.dynamics.Payload(1.3, com=(0.02, -0.01, 0.07), inertia=np.diag([0.004, 0.005, 0.003]))
    _check_terms(with_payload(rr.models.panda(), load), np.random.default_rng(2), 500)


def test_prismatic_joints_and_armature_equal_pinocchio() -> None:
    rng = np.random.default_rng(3)
    links = []
    for kind in ["revolute", "prismatic", "revolute", "revolute", "prismatic", "revolute"]:
        A = rng.standard_normal((3, 3))
        links.append({
            "a": rng.uniform(-0.4, 0.4), "alpha": rng.uniform(-np.pi, np.pi),
            "d": rng.uniform(-0.4, 0.4), "theta": rng.uniform(-np.pi, np.pi), "joint": kind,
            "q_min": -0.5, "q_max": 0.5, "mass": rng.uniform(0.5, 3.0),
            "com": rng.uniform(-0.1, 0.1, 3), "inertia": A @ A.T * 0.01 + 0.01 * np.eye(3),
            "armature": rng.uniform(0.0, 0.3),
        })  # fmt: skip
    robot = rr.Robot.from_dh(links, "modified", base=np.eye(4))
    assert robot.model.armature.max() > 0.0
    _check_terms(robot, rng, 1_000)


def test_a_chain_that_misses_joints_is_refused() -> None:
    robot = rr.Robot.from_urdf(
        Path(__file__).parents[1] / "fixtures" / "panda_description.urdf", tip="panda_hand_tcp"
    )
    with pytest.raises(NotSerialChainError, match="holds 4 of the model's 7 joints"):
        ChainDynamics(robot, "panda_link4")
    assert chain_dynamics(robot, "panda_link4") is None


def test_terms_refuse_bad_input() -> None:
    dyn = ChainDynamics(rr.models.panda())
    with pytest.raises(ShapeError, match="q must have shape"):
        dyn.terms(np.zeros(6), np.zeros(7))
    with pytest.raises(NonFiniteError, match="qd contains NaN"):
        dyn.terms(np.zeros(7), np.full(7, np.nan))


LAWS = {
    "posture, exact": dict(objectives=[(PostureObjective(), 1.0)]),
    "two costs, damped": dict(
        objectives=[(JointLimitObjective(), 2.0), (PostureObjective(), 0.5)], damping=0.02
    ),
    "no cost, adaptive": dict(objectives=[], damping=AdaptiveDamping(0.1, 0.05)),
    "position rows, gains per row": dict(task=PositionTask(), kp=[100.0, 200.0, 300.0], kd=20.0),
}


@pytest.mark.parametrize("law", list(LAWS))
def test_compiled_osc_step_equals_the_pinocchio_path(law: str, arm: rr.Robot) -> None:
    rng = np.random.default_rng(11)
    settings = LAWS[law]

    def make() -> OperationalSpaceController:
        kw = dict(settings)
        if "task" in kw:
            kw["task"] = type(kw["task"])()
        return OperationalSpaceController(**kw)  # type: ignore[arg-type]

    fast, slow = make(), make()
    slow._compiled = (arm, None)  # the Pinocchio path, for ever
    traj = rr.control.Circle(arm.fk(arm.neutral()), radius=0.05, period=2.0)
    worst = 0.0
    for k, (q, qd) in enumerate(_states(arm, rng, 200)):
        q = 0.3 * q + 0.7 * arm.neutral()
        sample = traj.sample(0.01 * k) if k % 2 else None
        a, b = fast.step(arm, q, qd, sample), slow.step(arm, q, qd, sample)
        for x, y in ((a.tau, b.tau), (a.tau_null, b.tau_null), (a.extra["tau0"], b.extra["tau0"]),
                     (a.error, b.error), (a.pose, b.pose), (a.target, b.target)):  # fmt: skip
            worst = max(worst, float(np.abs(x - y).max()) / max(1.0, float(np.abs(y).max())))
        assert a.info.rank == b.info.rank and a.info.method == b.info.method
        assert a.info.sigma_min == pytest.approx(b.info.sigma_min, rel=1e-9, abs=1e-12)
    assert fast._compiled is not None and fast._compiled[1] is not None
    assert fast._compiled[1]._entry is not None  # the kernel ran, not the fallback
    assert worst < 1e-11


@pytest.mark.parametrize(
    "kw",
    [
        dict(projector="kinematic"),
        dict(compensation="task"),
        dict(null_torque=lambda robot, q, qd: np.zeros(robot.n)),
        dict(objectives=[(ManipulabilityObjective(), 1.0)]),
    ],
    ids=["kinematic projector", "task compensation", "null torque", "manipulability"],
)
def test_laws_the_kernel_does_not_cover_take_the_pinocchio_path(kw: dict, panda: rr.Robot) -> None:
    law = OperationalSpaceController(**kw)
    step = law.step(panda, panda.neutral(), np.zeros(panda.n))
    assert law._compiled is not None and law._compiled[1] is None
    assert np.isfinite(step.tau).all()


def test_compiled_osc_step_names_bad_input(panda: rr.Robot) -> None:
    law = OperationalSpaceController(task=FrameTask())
    law.step(panda, panda.neutral(), np.zeros(7))
    with pytest.raises(ShapeError, match="q must have shape"):
        law.step(panda, np.zeros(6), np.zeros(7))
    with pytest.raises(NonFiniteError, match="qd contains NaN"):
        law.step(panda, panda.neutral(), np.full(7, np.nan))
    with pytest.raises(NonFiniteError, match="q contains NaN"):
        law.step(panda, np.full(7, np.inf), np.zeros(7))


def test_settings_changed_between_runs_reach_the_compiled_step(panda: rr.Robot) -> None:
    fast = OperationalSpaceController(objectives=[(PostureObjective(), 1.0)])
    slow = OperationalSpaceController(objectives=[(PostureObjective(), 1.0)])
    slow._compiled = (panda, None)
    q, qd = panda.neutral() + 0.1, np.full(panda.n, 0.2)
    fast.step(panda, q, qd)
    for law in (fast, slow):
        law.damping, law.null_law.kd = 0.05, 3.0
        law.reset()
    slow._compiled = (panda, None)
    a, b = fast.step(panda, q, qd), slow.step(panda, q, qd)
    assert a.info.damping == b.info.damping == 0.05
    assert np.abs(a.tau - b.tau).max() < 1e-10 * max(1.0, float(np.abs(b.tau).max()))


def test_the_compiled_step_is_read_from_the_kernel_output(panda: rr.Robot) -> None:
    """The compiled step's result (KernelControlStep) reads its fields from the kernel's
    output: the same values as the Pinocchio path's ControlStep, immutable, its own copy."""
    from redres.dynamics.chain import KernelControlStep

    fast = OperationalSpaceController(objectives=[(PostureObjective(), 1.0)])
    slow = OperationalSpaceController(objectives=[(PostureObjective(), 1.0)])
    slow._compiled = (panda, None)
    q, qd = panda.neutral() + 0.1, np.full(panda.n, 0.2)
    a, b = fast.step(panda, q, qd), slow.step(panda, q, qd)
    assert isinstance(a, KernelControlStep) and "_info" not in a.__dict__  # not read yet
    assert a.info is a.info and a.info.rank == b.info.rank == 6 and a.info.full_rank
    assert a.info.sigma_min == pytest.approx(b.info.sigma_min, rel=1e-12)
    assert a.info.sigma_max == pytest.approx(b.info.sigma_max, rel=1e-12)
    assert a.info.method == b.info.method and a.info.damping == b.info.damping == 0.0
    for name in ("tau", "tau_null", "error", "pose", "target"):
        x, y = getattr(a, name), getattr(b, name)
        assert np.abs(x - y).max() < 1e-11 * max(1.0, float(np.abs(y).max())), name
    assert np.allclose(a.extra["tau0"], b.extra["tau0"], rtol=1e-12, atol=1e-12)
    with pytest.raises(AttributeError):
        a.tau = np.zeros(panda.n)  # type: ignore[misc]
    tau = a.tau.copy()
    q_view = np.repeat(q, 2)[::2]  # strided: the validated copy, not the fast lane
    later = fast.step(panda, q_view, qd)
    assert np.array_equal(later.tau, tau) and np.array_equal(a.tau, tau)  # a's own copy
    assert np.array_equal(fast.step(panda, q.tolist(), qd).tau, tau)


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_compiled_osc_torque_equals_the_pinocchio_path_on_10000_states(name: str) -> None:
    """Random states over the whole joint range (10,000 when compiled; the plain-Python
    twin runs 300). Both paths take the task and null-space torques from QR of
    ``[J M^{-1/2}; λ I]ᵀ`` (:mod:`redres.dynamics.consistent`), whose rounding grows with
    ``κ = κ(J M^{-1/2})``, not ``κ²`` as through ``J M⁻¹ Jᵀ`` (5.6e-12 before). Measured,
    relative to max(1, max|τ|): panda 2.9e-13 on all states; iiwa14 below 1e-12 on all
    but one state, 1.1e-5 m from a singularity (``σ_min(J)``; ``κ`` = 5e5): 1.7e-12 =
    0.015 κ ε, where 1-ulp changes of ``M`` or ``J`` move the torque by 2.5e-12 and the
    exact torques at the two paths' ``M``, ``J`` differ by 5e-13 (rational arithmetic).
    The bound is therefore max(1e-12, 0.1 κ ε)."""
    from redres import _compile

    worst = _osc_difference(rr.models.load(name), 10_000 if _compile.enabled() else 300)
    assert worst < 1.0, worst


def test_compiled_osc_torque_equals_the_pinocchio_path_on_file_robots_and_payloads(
    fixtures_dir: Path,
) -> None:
    """The URDF fixture, and the Panda with a 2 kg payload, as above: measured 1.0e-13 and
    5.8e-14 relative to max(1, max|τ|) on 1,000 states each."""
    from redres import _compile

    count = 1_000 if _compile.enabled() else 100
    urdf = rr.Robot.from_urdf(fixtures_dir / "panda_description.urdf", tip="panda_hand_tcp")
    load = rr.dynamics.Payload(2.0, com=(0.01, 0.02, 0.08), inertia=np.diag([0.01, 0.02, 0.01]))
    for robot in (urdf, with_payload(rr.models.panda(), load)):
        worst = _osc_difference(robot, count)
        assert worst < 1.0, worst


def _osc_difference(arm: rr.Robot, count: int) -> float:
    """The largest ``|Δτ| / max(1, max|τ|)`` between the compiled OSC step and its Pinocchio
    path over ``count`` random states, in units of its bound ``max(1e-12, 0.1 κ ε)``,
    ``κ = κ(J M^{-1/2})``."""
    fast = OperationalSpaceController(objectives=[(PostureObjective(), 1.0)])
    slow = OperationalSpaceController(objectives=[(PostureObjective(), 1.0)])
    slow._compiled = (arm, None)
    traj = rr.control.Circle(arm.fk(arm.neutral()), radius=0.05, period=2.0)
    worst = 0.0
    eps = float(np.finfo(float).eps)
    for k, (q, qd) in enumerate(_states(arm, np.random.default_rng(17), count)):
        sample = traj.sample(0.01 * k) if k % 2 else None
        a, b = fast.step(arm, q, qd, sample), slow.step(arm, q, qd, sample)
        scale = max(1.0, float(np.abs(b.tau).max()))
        bound = max(1e-12, 0.1 * b.info.sigma_max / b.info.sigma_min * eps)
        worst = max(worst, float(np.abs(a.tau - b.tau).max()) / scale / bound)
    assert fast._compiled is not None and fast._compiled[1] is not None
    return worst


@pytest.mark.parametrize(
    "damping",
    [0.0, AdaptiveDamping(0.1, 0.05, selective=True), AdaptiveDamping(0.1, 0.05)],
    ids=["exact (truncated)", "selective", "adaptive"],
)
def test_compiled_osc_step_at_a_singularity_equals_the_pinocchio_path(
    damping: float | AdaptiveDamping, panda: rr.Robot
) -> None:
    """At the stretched arm (``J M^{-1/2}`` of rank 5): the truncated or selectively damped
    ``J̄`` on both paths (not QR), and the adaptive damping's QR with the λ it chose."""
    fast = OperationalSpaceController(objectives=[(PostureObjective(), 1.0)], damping=damping)
    slow = OperationalSpaceController(objectives=[(PostureObjective(), 1.0)], damping=damping)
    slow._compiled = (panda, None)
    rng = np.random.default_rng(4)
    for _ in range(20):
        q, qd = np.zeros(panda.n), rng.uniform(-1.0, 1.0, panda.n)
        a, b = fast.step(panda, q, qd), slow.step(panda, q, qd)
        assert a.info.rank == b.info.rank == 5
        assert a.info.damping == pytest.approx(b.info.damping)
        assert np.abs(a.tau - b.tau).max() < 1e-12 * max(1.0, float(np.abs(b.tau).max()))
    assert fast._compiled is not None and fast._compiled[1] is not None
    assert fast._compiled[1]._entry is not None  # the kernel ran, not the fallback
