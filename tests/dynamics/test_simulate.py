"""The forward-dynamics simulator: integration, energy, torque limits, run logs, the Panda
circle under operational-space control, failures that name the step."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.control import Circle, Hold
from redres.dynamics import (
    GravityCompensation,
    OperationalSpaceController,
    Payload,
    TorqueFunction,
    ZeroTorque,
    dynamics_summary,
    simulate,
    with_gravity,
)
from redres.errors import (
    InvalidParameterError,
    JointLimitError,
    NonFiniteError,
    ShapeError,
    SimulationError,
)
from redres.objectives import PostureObjective
from redres.tasks import FrameTask


def test_one_step_is_semi_implicit_euler(panda, rng) -> None:
    """q̇₁ = q̇₀ + dt M⁻¹(τ − b), q₁ = q₀ + dt q̇₁ (M and b from CRBA/RNEA, not ABA)."""
    q0 = panda.random_configuration(rng, margin=0.2)
    qd0 = rng.uniform(-0.5, 0.5, panda.n)
    tau = rng.normal(size=panda.n)
    dt = 1e-3
    law = TorqueFunction(lambda robot, q, qd, sample: tau, "constant")
    log = simulate(panda, law, dt=dt, duration=dt, q0=q0, qd0=qd0)
    qdd = np.linalg.solve(panda.mass_matrix(q0), tau - panda.bias(q0, qd0))
    qd1 = qd0 + dt * qdd
    np.testing.assert_allclose(log.extra["final_qd"], qd1, atol=1e-12)
    np.testing.assert_allclose(log.extra["final_q"], q0 + dt * qd1, atol=1e-12)
    assert log.steps == 1


def test_energy_is_conserved_without_gravity_or_torque(panda, rng) -> None:
    """Zero torque, zero gravity, no damping: relative energy drift over 1 s at dt = 1e-4."""
    floating = with_gravity(panda, (0.0, 0.0, 0.0))
    q0 = panda.random_configuration(rng, margin=0.3)
    qd0 = rng.uniform(-1.0, 1.0, panda.n)
    log = simulate(floating, ZeroTorque(), dt=1e-4, duration=1.0, q0=q0, qd0=qd0)
    s = dynamics_summary(log)
    # Oracle for the energy itself: ½ q̇ᵀ M q̇ at the start, independent of the log.
    e0 = 0.5 * qd0 @ panda.mass_matrix(q0) @ qd0
    assert log.extra["energy"][0] == pytest.approx(e0, rel=1e-12)
    print(
        f"\nenergy drift over 1 s at dt = 1e-4: end {s['energy_drift_rel']:.2e}, "
        f"max {s['max_energy_deviation_rel']:.2e} (relative)"
    )
    assert abs(s["energy_drift_rel"]) < 1e-3
    assert s["max_energy_deviation_rel"] < 1e-3
    assert np.abs(log.extra["potential_energy"]).max() == 0.0


def test_energy_with_gravity_is_conserved_too(iiwa, rng) -> None:
    q0 = iiwa.random_configuration(rng, margin=0.3)
    log = simulate(
        iiwa,
        ZeroTorque(),
        dt=1e-4,
        duration=0.3,
        q0=q0,
        qd0=rng.uniform(-0.5, 0.5, iiwa.n),
        limit_torque=False,
    )
    s = dynamics_summary(log)
    assert abs(s["energy_drift_rel"]) < 1e-3


def test_gravity_compensation_holds_the_arm(panda) -> None:
    q0 = panda.neutral()
    log = simulate(panda, GravityCompensation(), dt=1e-3, duration=0.2, q0=q0)
    assert np.abs(log.extra["final_q"] - q0).max() < 1e-9
    assert np.abs(log.extra["final_qd"]).max() < 1e-9


@pytest.fixture(scope="module")
def circle_runs(panda):
    """The Panda's TCP on a 10 cm circle (4 s per turn, 0.5 s ramp) from neutral, OSC with a
    posture task in the null space, 1 kHz control and simulation, both projectors."""
    q0 = panda.neutral()
    circle = Circle(panda.fk(q0), 0.10, 4.0, ramp=0.5)
    runs = {}
    for projector in ("dynamic", "kinematic"):
        law = OperationalSpaceController(projector=projector, objectives=[PostureObjective(q0)])
        runs[projector] = simulate(panda, law, circle, dt=1e-3, q0=q0)
    return runs


def test_panda_tracks_a_circle_under_osc(circle_runs) -> None:
    table = {p: dynamics_summary(log) for p, log in circle_runs.items()}
    print(
        "\nprojector  max_err_m  rms_err_m  max_rot_rad  max|tau|/tau_max  max_disturb  rms_disturb"
    )
    for p, s in table.items():
        print(
            f"{p:9s}  {s['max_position_error_m']:.2e}  {s['rms_position_error_m']:.2e}  "
            f"{s['max_orientation_error_rad']:.2e}  {s['max_torque_ratio']:.3f}  "
            f"{s['max_task_disturbance']:.2e}  {s['rms_task_disturbance']:.2e}"
        )
    dyn, kin = table["dynamic"], table["kinematic"]
    assert dyn["steps"] == 4250
    assert dyn["max_position_error_m"] < 1e-4
    assert dyn["max_orientation_error_rad"] < 1e-4
    assert dyn["max_torque_ratio"] <= 1.0 and dyn["saturated_steps"] == 0
    assert dyn["max_task_disturbance"] < 1e-9
    assert kin["max_task_disturbance"] > 1e-2
    assert kin["max_position_error_m"] > dyn["max_position_error_m"]


def test_run_log_is_complete_and_finite(circle_runs, panda) -> None:
    log = circle_runs["dynamic"]
    K = log.steps
    arrays = """q qd position target position_error orientation_error sigma_min damping rank
        speed_ratio joint_limit_margin manipulability step_time_ns"""
    for name in arrays.split():
        values = np.asarray(getattr(log, name))
        assert values.shape[0] == K, name
        assert np.all(np.isfinite(values)), name
    for name in ("tau", "tau_command", "tau_null", "energy", "task_disturbance", "torque_ratio"):
        assert np.all(np.isfinite(log.extra[name])), name
    assert log.scheme == "osc_dynamic" and log.robot == "panda"
    np.testing.assert_allclose(log.t[1] - log.t[0], 1e-3)
    # Logged positions are the TCP's, targets the circle's.
    np.testing.assert_allclose(log.position[100], panda.fk(log.q[100])[:3, 3], atol=1e-12)
    assert set(log.objectives) == {"posture"}
    assert log.summary()["max_position_error_m"] == pytest.approx(log.position_error.max())


def test_torques_are_clipped_and_saturation_is_recorded(panda) -> None:
    big = 2.0 * panda.tau_max
    law = TorqueFunction(lambda robot, q, qd, sample: big, "too_strong")
    log = simulate(panda, law, dt=1e-3, duration=0.005)
    np.testing.assert_allclose(log.extra["tau"], np.tile(panda.tau_max, (log.steps, 1)))
    assert log.scaled.all() and log.extra["saturated"].all()
    assert dynamics_summary(log)["max_torque_ratio"] == pytest.approx(2.0)


def test_unknown_payload_and_dynamic_consistency(panda) -> None:
    """The law's model ignores a 2 kg load at the TCP: tracking suffers, but with the
    6-D task the null-space torque still never accelerates the task (load independence)."""
    q0 = panda.neutral()
    circle = Circle(panda.fk(q0), 0.10, 4.0, ramp=0.5)
    payload = Payload(2.0, (0.0, 0.0, 0.05), np.diag([0.01, 0.01, 0.005]))
    runs = {}
    for rows in (None, [0, 1, 2]):
        law = OperationalSpaceController(FrameTask(rows=rows), objectives=[PostureObjective(q0)])
        runs[rows is None] = dynamics_summary(
            simulate(panda, law, circle, duration=0.6, q0=q0, payload=payload)
        )
    six, three = runs[True], runs[False]
    assert six["max_task_disturbance"] < 1e-9
    assert three["max_task_disturbance"] > 1e-3
    assert six["max_position_error_m"] > 1e-4  # the unmodelled load does show


def test_substeps_and_progress(panda, capsys) -> None:
    log = simulate(
        panda, GravityCompensation(kd=1.0), dt=2e-4, duration=0.01, substeps=5, progress=True
    )
    assert log.steps == 10
    np.testing.assert_allclose(log.dt, 1e-3)
    assert log.extra["substeps"] == 5


# ---------------------------------------------------------------- failures


def test_nan_torque_stops_with_the_step_named(panda) -> None:
    calls = {"n": 0}

    def law(robot, q, qd, sample):
        calls["n"] += 1
        return np.full(robot.n, np.nan) if calls["n"] == 4 else robot.gravity(q)

    with pytest.raises(SimulationError, match="step 3"):
        simulate(panda, TorqueFunction(law, "nan_at_3"), duration=0.01)


def test_diverging_state_stops_with_the_step_named(panda) -> None:
    law = TorqueFunction(lambda robot, q, qd, sample: np.full(robot.n, 1e306), "huge")
    with pytest.raises(
        SimulationError, match=r"step \d+ \(t = .* s\): the state became non-finite"
    ):
        simulate(panda, law, duration=0.01, limit_torque=False)


def test_unstable_gains_never_give_nan(panda) -> None:
    """An OSC run at a far too coarse step blows up: an error naming a step, not NaN."""
    q0 = panda.neutral()
    T = panda.fk(q0)
    T[:3, 3] += 0.05
    law = OperationalSpaceController(kp=1e6)
    with pytest.raises(SimulationError, match="step"):
        simulate(panda, law, Hold(T, 2.0), dt=1e-2, q0=q0, limit_torque=False)


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [
        (dict(dt=0.0), InvalidParameterError),
        (dict(dt=-1e-3), InvalidParameterError),
        (dict(duration=-1.0), InvalidParameterError),
        (dict(substeps=0), InvalidParameterError),
        (dict(substeps=1.5), InvalidParameterError),
        (dict(q0=np.full(7, np.nan)), NonFiniteError),
        (dict(qd0=np.zeros(6)), ShapeError),
        (dict(qd0=[0, 0, 0, np.inf, 0, 0, 0]), NonFiniteError),
        (dict(q0=np.full(7, 10.0)), JointLimitError),
    ],
)
def test_bad_arguments(panda, kwargs, error) -> None:
    args = dict(duration=0.01)
    args.update(kwargs)
    with pytest.raises(error):
        simulate(panda, ZeroTorque(), **args)


def test_bad_laws(panda) -> None:
    with pytest.raises(InvalidParameterError, match="TorqueLaw"):
        simulate(panda, lambda *a: 0, duration=0.01)  # type: ignore[arg-type]
    with pytest.raises(InvalidParameterError, match="duration"):
        simulate(panda, ZeroTorque())
    with pytest.raises(ShapeError, match="controller_robot"):
        simulate(panda, ZeroTorque(), duration=0.01, controller_robot=rr.models.planar([1, 1]))
    short = TorqueFunction(lambda robot, q, qd, sample: np.zeros(3), "short")
    with pytest.raises(ShapeError, match="short"):
        simulate(panda, short, duration=0.01)


def test_other_robots_run(builtin_robots: dict[str, rr.Robot]) -> None:
    robot = builtin_robots["srs7"]
    law = OperationalSpaceController(objectives=[PostureObjective()])
    log = simulate(robot, law, duration=0.05)
    assert np.all(np.isfinite(log.q))
    assert dynamics_summary(log)["max_position_error_m"] < 1e-6
