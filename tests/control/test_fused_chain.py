"""The controller's compiled paths with the frame's kinematics from its serial chain.

Oracle: the same controller fed by Pinocchio (``serial_chain`` patched to None: the
placement and Jacobian of one Pinocchio call per step, today's path), step by step along
a circle in closed loop, on the Panda, the iiwa14, a planar arm and DH robots with
prismatic joints, for the fused path and for the frame path (hard-limit schemes, their
velocity and acceleration limits); and the kernels' plain-Python twin (the path taken
while they compile behind).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres import _compile as _jit
from redres.control import Circle, Controller
from redres.control import controller as controller_module
from redres.linalg import AdaptiveDamping, _backend
from redres.objectives import JointLimitObjective, PostureObjective
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme, Scheme, SNSScheme
from redres.tasks import FrameTask

TOL = 1e-12
DT = 1e-3
_KERNELS = "redres.control._kernels"


@pytest.fixture(autouse=True)
def _compiled() -> None:
    if _backend.kernels() is None:
        pytest.skip("compiled kernels unavailable")


def dh_robot(rng: np.random.Generator, convention: str) -> rr.Robot:
    """Six joints, two of them prismatic, random DH parameters, base and tool."""
    links = []
    for kind in ["revolute", "prismatic", "revolute", "revolute", "prismatic", "revolute"]:
        link: dict[str, object] = {
            "a": rng.uniform(-0.4, 0.4), "alpha": rng.uniform(-np.pi, np.pi),
            "d": rng.uniform(-0.4, 0.4), "theta": rng.uniform(-np.pi, np.pi), "joint": kind,
        }  # fmt: skip
        if kind == "prismatic":
            link["q_min"], link["q_max"] = -0.3, 0.4
        links.append(link)
    base, tool = (np.asarray(pin.exp6(rng.uniform(-1, 1, 6)).homogeneous) for _ in range(2))
    return rr.Robot.from_dh(links, convention, base=base, tool=tool)  # type: ignore[arg-type]


def robots(rng: np.random.Generator) -> list[tuple[rr.Robot, list[str] | None]]:
    """The robots of the comparison, with the frame task's rows."""
    return [
        (rr.models.panda(), None),
        (rr.models.iiwa14(), None),
        (rr.models.planar([1.0, 0.8, 0.5]), ["x", "y"]),
        (dh_robot(rng, "standard"), None),
        (dh_robot(rng, "modified"), ["x", "y", "z", "rz"]),
    ]


def make(robot: rr.Robot, rows: Any, scheme: Scheme, *, pinocchio: bool = False,
         monkeypatch: pytest.MonkeyPatch | None = None, **kwargs: Any) -> Controller:  # fmt: skip
    """A controller on a fresh frame task; fed by Pinocchio when ``pinocchio``."""
    if pinocchio:
        assert monkeypatch is not None
        with monkeypatch.context() as patch:
            patch.setattr(controller_module, "serial_chain", lambda robot, frame: None)
            return Controller(robot, FrameTask(rows=rows), scheme, dt=DT, **kwargs)
    return Controller(robot, FrameTask(rows=rows), scheme, dt=DT, **kwargs)


def compare_along_a_circle(
    a: Controller, b: Controller, q0: np.ndarray, steps: int, tol: float = TOL
) -> None:
    """Both controllers follow the same circle from ``q0``, each from its own state; every
    step's configuration and diagnostics agree to ``tol``."""
    robot = a.robot
    circle = Circle(robot.fk(q0), radius=0.03, period=0.25, ramp=0.05)
    qa, qb = q_from = q0.copy(), q0.copy()
    for k in range(steps):
        sample = circle.sample(k * DT)
        for c in (a, b):
            c.task.set_target(sample.pose, sample.twist, validate=False)  # type: ignore[attr-defined]
        q_from = qa
        qa, qb = a.step(qa), b.step(qb)
        where = f"{robot.name}, step {k}"
        for got, expected, what in (
            (qa, qb, "q"), (a.qd, b.qd, "qd"), (a.error, b.error, "error"),
            (a.pose, b.pose, "pose"),
        ):  # fmt: skip
            np.testing.assert_allclose(got, expected, rtol=0, atol=tol, err_msg=f"{what}, {where}")
        ia, ib = a.info, b.info
        assert (ia.rank, ia.full_rank, ia.method) == (ib.rank, ib.full_rank, ib.method), where
        for x, y in ((ia.sigma_min, ib.sigma_min), (ia.sigma_max, ib.sigma_max),
                     (ia.damping, ib.damping), (a.speed_ratio, b.speed_ratio)):  # fmt: skip
            assert abs(x - y) <= tol * max(1.0, abs(y)), where
        assert a.scaled == b.scaled, where
    np.testing.assert_allclose(a.pose, robot.fk(q_from), rtol=0, atol=TOL)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "scheme",
    [
        lambda: GradientProjectionScheme([JointLimitObjective()], k_null=5.0, damping=0.01),
        lambda: GradientProjectionScheme(
            [(JointLimitObjective(), 2.0), (PostureObjective(weights=0.3), 0.5)], k_null=2.0
        ),
        lambda: PseudoInverseScheme(damping=AdaptiveDamping(0.1, 0.3)),
    ],
    ids=["joint-limits", "two-costs", "adaptive"],
)
@pytest.mark.parametrize("limit", [True, False], ids=["limited", "unlimited"])
def test_the_chain_fed_fused_step_equals_the_pinocchio_fed_one(
    scheme: Any, limit: bool, rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch
) -> None:
    for robot, rows in robots(rng):
        q0 = robot.random_configuration(rng, margin=0.2)
        chain = make(robot, rows, scheme(), gain=80.0, limit_velocity=limit)
        pinocchio = make(robot, rows, scheme(), pinocchio=True, monkeypatch=monkeypatch,
                         gain=80.0, limit_velocity=limit)  # fmt: skip
        assert (chain.path, chain.kinematics) == ("fused", "chain")
        assert (pinocchio.path, pinocchio.kinematics) == ("fused", "pinocchio")
        compare_along_a_circle(chain, pinocchio, q0, 300)


class OwnStepGradient(GradientProjectionScheme):
    """Gradient projection with its own ``_step`` (the parent's): the frame path."""

    def _step(self, robot: Any, q: Any, J: Any, xd: Any) -> Any:
        return super()._step(robot, q, J, xd)


@pytest.mark.parametrize("kind", ["gradient", "sns"])
def test_the_chain_fed_frame_path_equals_the_pinocchio_fed_one(
    kind: str, rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The frame path's front end, with a damped scheme and with SNS (velocity and
    acceleration limits held). SNS inverts the Jacobian of its unsaturated joints without
    damping, which amplifies the kinematics' rounding differences (1e-16) by its
    conditioning: up to 2e-12 rad/s seen at σ_min = 0.04, hence its looser tolerance."""
    tol = TOL if kind == "gradient" else 1e-10
    for robot, rows in robots(rng):
        q0 = robot.random_configuration(rng, margin=0.2)
        pair = [
            make(robot, rows, OwnStepGradient([JointLimitObjective()], k_null=5.0, damping=0.01)
                 if kind == "gradient" else
                 SNSScheme(dt=DT, objectives=[JointLimitObjective()], k_null=2.0),
                 pinocchio=pinocchio, monkeypatch=monkeypatch, gain=80.0)
            for pinocchio in (False, True)
        ]  # fmt: skip
        assert [(c.path, c.kinematics) for c in pair] == [("frame", "chain"),
                                                          ("frame", "pinocchio")]  # fmt: skip
        compare_along_a_circle(*pair, q0, 200, tol)


def test_a_robot_that_is_not_a_serial_chain_up_to_the_frame_takes_pinocchio() -> None:
    """A tree: the frame on a branch after another branch point is fed by Pinocchio, the
    one whose chain is serial by the kernel; both equal the composed step."""
    model = pin.Model()
    model.name = "tree"
    trunk = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "trunk")
    left = model.addJoint(trunk, pin.JointModelRY(), pin.SE3(np.eye(3), np.array([0.0, 0.3, 0.5])),
                          "left")  # fmt: skip
    right = model.addJoint(trunk, pin.JointModelRX(), pin.SE3(np.eye(3), np.array([0.4, 0, 0.5])),
                           "right")  # fmt: skip
    for name, joint in (("left_tip", left), ("right_tip", right)):
        placement = pin.SE3(np.eye(3), np.array([0.0, 0.0, 0.4]))
        model.addFrame(pin.Frame(name, joint, 0, placement, pin.FrameType.OP_FRAME))
    robot = rr.Robot(model, tip="right_tip")
    q = np.array([0.3, -0.7, 1.1])
    for frame, kinematics in (("left_tip", "chain"), ("right_tip", "pinocchio")):
        task, composed = FrameTask(frame, rows=["x", "y"]), FrameTask(frame, rows=["x", "y"])
        controller = Controller(robot, task, PseudoInverseScheme(damping=0.05), gain=10.0)
        assert controller.kinematics == kinematics
        target = robot.fk(q, frame)
        target[:2, 3] += [0.02, -0.01]
        task.set_target(target)
        composed.set_target(target)
        state = composed.compute(robot, q)
        qd = rr.linalg.damped_pinv(state.jacobian, 0.05) @ state.command(10.0)
        np.testing.assert_allclose(controller.step(q), q + qd * DT, rtol=0, atol=1e-14)
        np.testing.assert_allclose(controller.pose, robot.fk(q, frame), rtol=0, atol=1e-14)  # type: ignore[arg-type]


def test_the_kinematics_and_the_diagnostics_before_a_step() -> None:
    robot = rr.models.panda()
    controller = Controller(robot, FrameTask(), PseudoInverseScheme())
    assert controller.kinematics == "chain"
    assert controller.pose is None and controller.error.shape == (0,)
    assert controller.speed_ratio == 0.0 and not controller.scaled
    with pytest.raises(rr.errors.InvalidParameterError, match="not made a step"):
        controller.info  # noqa: B018
    composed = Controller(robot, rr.tasks.PostureTask(robot.neutral()), PseudoInverseScheme())
    assert composed.kinematics == "task"


def test_the_plain_python_twin_gives_the_compiled_step(rng: np.random.Generator) -> None:
    """While the kernels compile behind the controller runs their plain-Python twin: it
    computes the same block as the compiled kernel."""
    robot = rr.models.panda()
    controller = Controller(robot, FrameTask(), GradientProjectionScheme([JointLimitObjective()]))
    q = robot.random_configuration(rng, margin=0.2)
    controller.task.set_target(robot.fk(robot.random_configuration(rng)))  # type: ignore[attr-defined]
    q_compiled = controller.step(q)
    compiled = controller._out
    twin = _jit.groups()["controller"].module(plain=True)
    assert not _jit.is_compiled(twin)
    q_next, out = np.empty_like(q), np.empty_like(compiled)
    assert twin.chain_step(controller._config, q, q_next, out) == 0
    np.testing.assert_allclose(out, compiled, rtol=0, atol=TOL)
    np.testing.assert_allclose(q_next, q_compiled, rtol=0, atol=TOL)
