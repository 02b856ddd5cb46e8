"""Compiled serial-chain kinematics (redres.robot.chain) against Pinocchio, the reference:
pose, world-aligned and local Jacobians to 1e-12 on every built-in model, the URDF fixture,
DH robots with prismatic joints and random chains of every accepted joint kind, at
configurations inside and outside the limits and on every frame; the refusal of models
that are not serial chains; the SO(3) logarithm near 0 and π; the frame task's error."""

from __future__ import annotations

import copy
import importlib.util
import pickle
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres import _compile as _jit
from redres.errors import NonFiniteError, ShapeError
from redres.robot.chain import NotSerialChainError, SerialChain, log3
from redres.tasks import FrameTask

TOL = 1e-12
SRC = Path(__file__).resolve().parents[2] / "src"


def configurations(robot: rr.Robot, rng: np.random.Generator, count: int = 6) -> list[np.ndarray]:
    """Random configurations within the limits, half of them then pushed outside."""
    span = robot.q_max - robot.q_min
    out = [robot.random_configuration(rng) for _ in range(count)]
    out += [robot.q_min - rng.uniform(0, 1, robot.n) * span for _ in range(count // 2)]
    out += [robot.q_max + rng.uniform(0, 1, robot.n) * span for _ in range(count // 2)]
    return out


def close(got: np.ndarray, expected: np.ndarray, what: str) -> None:
    scale = max(1.0, float(np.abs(expected).max()))
    np.testing.assert_allclose(got, expected, rtol=0, atol=TOL * scale, err_msg=what)


def check_robot(robot: rr.Robot, rng: np.random.Generator, count: int = 6) -> None:
    """Every frame of ``robot``: the chain's pose and both Jacobians equal the Robot's."""
    for q in configurations(robot, rng, count):
        for frame in robot.frames():
            chain = robot.chain(frame)
            where = f"{robot.name}, frame {frame}, q={q}"
            T, J = chain.kinematics(q)
            close(T, robot.fk(q, frame), f"pose, {where}")
            close(J, robot.jacobian(q, frame), f"world Jacobian, {where}")
            close(chain.fk(q), T, f"fk, {where}")
            local = robot.jacobian(q, frame, reference="local")
            close(chain.jacobian(q, "local"), local, f"local Jacobian, {where}")


@pytest.mark.parametrize("name", rr.models.names())
def test_every_builtin_model_equals_pinocchio(name: str, rng: np.random.Generator) -> None:
    check_robot(rr.models.load(name), rng)


def test_urdf_fixture_equals_pinocchio(fixtures_dir: Path, rng: np.random.Generator) -> None:
    robot = rr.Robot.from_urdf(fixtures_dir / "panda_description.urdf", tip="panda_hand_tcp")
    robot.add_frame("camera", "panda_link4", pin.SE3.Random().homogeneous)
    check_robot(robot, rng)


def dh_links(rng: np.random.Generator, kinds: list[str]) -> list[dict[str, object]]:
    links: list[dict[str, object]] = []
    for kind in kinds:
        link: dict[str, object] = {
            "a": rng.uniform(-0.5, 0.5),
            "alpha": rng.uniform(-np.pi, np.pi),
            "d": rng.uniform(-0.5, 0.5),
            "theta": rng.uniform(-np.pi, np.pi),
            "joint": kind,
        }
        if kind == "prismatic":
            link["q_min"], link["q_max"] = -0.3, 0.4
        links.append(link)
    return links


def random_pose(rng: np.random.Generator) -> np.ndarray:
    return np.asarray(pin.exp6(rng.uniform(-1, 1, 6)).homogeneous)


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_dh_robots_with_prismatic_joints(convention: str, rng: np.random.Generator) -> None:
    kinds = ["revolute", "prismatic", "revolute", "revolute", "prismatic", "revolute"]
    robot = rr.Robot.from_dh(
        dh_links(rng, kinds),
        convention,  # type: ignore[arg-type]
        base=random_pose(rng),
        tool=random_pose(rng),
        frames={"marker": ("link3", random_pose(rng))},
    )
    robot.add_frame("camera", "marker", random_pose(rng))
    check_robot(robot, rng)


def test_random_dh_chains(rng: np.random.Generator) -> None:
    """25 random DH robots: random length, joint kinds, convention, base and tool."""
    for _ in range(25):
        kinds = list(rng.choice(["revolute", "prismatic"], size=int(rng.integers(1, 9))))
        convention = "standard" if rng.random() < 0.5 else "modified"
        robot = rr.Robot.from_dh(
            dh_links(rng, kinds),
            convention,  # type: ignore[arg-type]
            base=random_pose(rng),
            tool=random_pose(rng),
        )
        check_robot(robot, rng, count=2)


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)


JOINTS: dict[str, Callable[[np.random.Generator], object]] = {
    "RX": lambda rng: pin.JointModelRX(),
    "RY": lambda rng: pin.JointModelRY(),
    "RZ": lambda rng: pin.JointModelRZ(),
    "revolute unaligned": lambda rng: pin.JointModelRevoluteUnaligned(_unit(rng)),
    "RUBX": lambda rng: pin.JointModelRUBX(),
    "RUBY": lambda rng: pin.JointModelRUBY(),
    "RUBZ": lambda rng: pin.JointModelRUBZ(),
    "revolute unbounded unaligned": lambda rng: pin.JointModelRevoluteUnboundedUnaligned(),
    "PX": lambda rng: pin.JointModelPX(),
    "PY": lambda rng: pin.JointModelPY(),
    "PZ": lambda rng: pin.JointModelPZ(),
    "prismatic unaligned": lambda rng: pin.JointModelPrismaticUnaligned(_unit(rng)),
}


def random_model(rng: np.random.Generator, kinds: list[str]) -> pin.Model:
    """A Pinocchio chain of ``kinds`` with random placements and a frame on every joint."""
    model = pin.Model()
    parent = 0
    for i, kind in enumerate(kinds):
        placement, fixed = pin.exp6(rng.uniform(-1, 1, 6)), pin.exp6(rng.uniform(-1, 1, 6))
        parent = model.addJoint(parent, JOINTS[kind](rng), placement, f"j{i}")
        model.addFrame(pin.Frame(f"f{i}", parent, 0, fixed, pin.FrameType.OP_FRAME))
    return model


def pinocchio_q(model: pin.Model, angles: np.ndarray) -> np.ndarray:
    """Pinocchio's configuration for tangent values (unbounded joints hold cos, sin)."""
    q = np.empty(model.nq)
    for joint in list(model.joints)[1:]:
        x = angles[joint.idx_v]
        if joint.nq == 2:
            q[joint.idx_q : joint.idx_q + 2] = np.cos(x), np.sin(x)
        else:
            q[joint.idx_q] = x
    return q


def check_model(model: pin.Model, rng: np.random.Generator) -> None:
    data = model.createData()
    for _ in range(3):
        angles = rng.uniform(-7, 7, model.nv)
        q = pinocchio_q(model, angles)
        pin.computeJointJacobians(model, data, q)
        for fid in range(len(model.frames)):
            chain = SerialChain(model, fid)
            placement = pin.updateFramePlacement(model, data, fid)
            T, J = chain.kinematics(angles)
            where = f"frame {model.frames[fid].name} of {model.name}"
            close(T, placement.homogeneous, f"pose, {where}")
            world = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            close(J, world.reshape(6, -1), f"world Jacobian, {where}")
            local = pin.getFrameJacobian(model, data, fid, pin.LOCAL).reshape(6, -1)
            close(chain.jacobian(angles, "local"), local, f"local Jacobian, {where}")


@pytest.mark.parametrize("kind", sorted(JOINTS))
def test_each_joint_kind_equals_pinocchio(kind: str, rng: np.random.Generator) -> None:
    check_model(random_model(rng, [kind, "RZ", kind, "PX", kind]), rng)


def test_random_chains_of_mixed_joint_kinds(rng: np.random.Generator) -> None:
    """25 random Pinocchio chains: random lengths, joint kinds, placements and frames."""
    names = sorted(JOINTS)
    for i in range(25):
        kinds = [names[k] for k in rng.integers(0, len(names), int(rng.integers(1, 10)))]
        model = random_model(rng, kinds)
        model.name = f"random{i}"
        check_model(model, rng)


# ---------------------------------------------------------------------- refusals


def test_a_branch_before_the_frame_is_refused_by_name() -> None:
    model = pin.Model()
    model.name = "tree"
    trunk = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "trunk")
    left = model.addJoint(trunk, pin.JointModelRY(), pin.SE3.Random(), "left")
    right = model.addJoint(trunk, pin.JointModelRY(), pin.SE3.Random(), "right")
    model.addFrame(pin.Frame("left_tip", left, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME))
    model.addFrame(pin.Frame("right_tip", right, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME))
    robot = rr.Robot(model, tip="right_tip")
    with pytest.raises(NotSerialChainError, match="joint 'left' is not on the chain.*'trunk'"):
        robot.chain()
    with pytest.raises(ValueError, match="use the Pinocchio path"):
        robot.chain("right_tip")
    # A branch after the frame is no obstacle: its joints get zero columns.
    q = np.array([0.3, -0.7, 1.1])
    chain = robot.chain("left_tip")
    close(chain.jacobian(q), robot.jacobian(q, "left_tip"), "left branch")
    assert chain.joints == ("trunk", "left")


def test_a_free_flyer_is_refused_by_name() -> None:
    model = pin.Model()
    model.name = "floating"
    base = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "floating_base")
    arm = model.addJoint(base, pin.JointModelRZ(), pin.SE3.Random(), "arm")
    model.addFrame(pin.Frame("hand", arm, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME))
    message = "joint 'floating_base' is a free-flyer .*nq=7, nv=6.*revolute and prismatic"
    with pytest.raises(NotSerialChainError, match=message):
        SerialChain(model, "hand")


@pytest.mark.parametrize(
    ("joint", "why"),
    [
        (pin.JointModelSpherical(), "a spherical joint"),
        (pin.JointModelPlanar(), "a planar joint"),
        (pin.JointModelHX(), "a helical joint"),
        (pin.JointModelUniversal(np.array([1.0, 0, 0]), np.array([0, 1.0, 0])), "a universal"),
    ],
)
def test_other_joints_are_refused_by_name(joint: object, why: str) -> None:
    model = pin.Model()
    jid = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "first")
    model.addFrame(pin.Frame("first", jid, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME))
    jid = model.addJoint(jid, joint, pin.SE3.Random(), "odd")
    model.addFrame(pin.Frame("tip", jid, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME))
    with pytest.raises(NotSerialChainError, match=f"joint 'odd' is {why}"):
        SerialChain(model, "tip")
    SerialChain(model, "first")  # the frames before it still compile


MIMIC_URDF = """<robot name="mimic">
  <link name="base"/><link name="l1"/><link name="l2"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="1 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
    <mimic joint="j1" multiplier="2" offset="0"/></joint>
</robot>"""


def test_a_mimic_joint_is_refused_by_name(tmp_path: Path) -> None:
    path = tmp_path / "mimic.urdf"
    path.write_text(MIMIC_URDF, encoding="utf-8")
    model = pin.buildModelFromUrdf(str(path), mimic=True)
    with pytest.raises(NotSerialChainError, match="joint 'j2' is a mimic joint"):
        SerialChain(model, "l2")


def test_an_unknown_frame_lists_the_valid_ones() -> None:
    with pytest.raises(KeyError, match="valid frames: .*tool"):
        SerialChain(rr.models.planar([1.0, 1.0]).model, "nowhere")


# ---------------------------------------------------------------------- log3, pose error


ANGLES_NEAR_0_AND_PI = [0.0, 1e-15, 1e-12, 1e-8, 1e-5, 1e-3, 0.3, np.pi / 2 - 1e-9, np.pi / 2]
ANGLES_NEAR_0_AND_PI += [np.pi / 2 + 1e-9, 2.0, np.pi - 1e-3, np.pi - 1e-6, np.pi - 1e-9]
ANGLES_NEAR_0_AND_PI += [np.pi - 1e-12, np.pi]


@pytest.mark.parametrize("angle", ANGLES_NEAR_0_AND_PI)
def test_log3_matches_pinocchio_near_0_and_pi(angle: float, rng: np.random.Generator) -> None:
    axes = [_unit(rng) for _ in range(20)] + list(np.eye(3)) + [-np.eye(3)[1]]
    for axis in axes:
        R = pin.exp3(angle * axis)
        got, expected = log3(R), pin.log3(R)
        if angle > np.pi - 1e-6 and got @ expected < 0:  # θ u and −θ u: both logarithms
            expected = -expected
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-13)
        np.testing.assert_allclose(pin.exp3(got), R, rtol=0, atol=1e-14)
        assert abs(np.linalg.norm(got) - angle) <= 1e-13 + 1e-13 * angle


def test_log3_of_a_stack_is_each_one_alone(rng: np.random.Generator) -> None:
    """The stacked form (the self-motion sweeps' corrector) is the single form per row,
    bit for bit, at 0 and π too."""
    angles = [0.0, 1e-9, 0.3, 2.0, np.pi - 1e-9, np.pi]
    stack = np.array([pin.exp3(a * _unit(rng)) for a in angles])
    rows = log3(stack)
    assert rows.shape == (len(angles), 3)
    for R, row in zip(stack, rows, strict=True):
        assert np.array_equal(row, log3(R))
    with pytest.raises(ShapeError, match=r"\(3, 3\) or \(N, 3, 3\)"):
        log3(np.eye(4))
    for bad in (np.nan, np.inf):  # by name, never a NaN logarithm
        R = np.eye(3)
        R[1, 2] = bad
        with pytest.raises(NonFiniteError, match="R contains NaN or infinity"):
            log3(R)
        with pytest.raises(NonFiniteError, match="R contains NaN or infinity"):
            log3(np.stack([np.eye(3), R]))


def test_log3_of_a_slightly_non_orthogonal_matrix_stays_finite() -> None:
    """Rounding can put the trace a hair outside [−1, 3]: no NaN."""
    for R in (np.diag([1.0, -1.0, -1.0]) * (1 + 1e-15), np.eye(3) * (1 + 1e-15)):
        assert np.isfinite(log3(R)).all()


def test_pose_error_equals_the_frame_task(rng: np.random.Generator) -> None:
    for name in ("panda", "iiwa14"):
        robot = rr.models.load(name)
        task = FrameTask()
        for _ in range(10):
            q, q_target = robot.random_configuration(rng), robot.random_configuration(rng)
            target = robot.fk(q_target)
            task.set_target(target)
            state = task.compute(robot, q)
            result = robot.chain().pose_error(q, target)
            unchecked = robot.chain().pose_error(q, target, validate=False)
            close(unchecked.error, result.error, "unchecked target")
            close(result.error, state.error, "error")
            close(result.jacobian, state.jacobian, "Jacobian")
            close(result.pose, robot.fk(q), "pose")
        # A target half a turn away about an axis: the error is the half turn.
        target = robot.fk(q) @ np.diag([1.0, -1.0, -1.0, 1.0])
        task.set_target(target)
        error = robot.chain().pose_error(q, target).error
        close(np.abs(error), np.abs(task.compute(robot, q).error), "half turn")
        assert abs(np.linalg.norm(error[3:]) - np.pi) < 1e-12


# ---------------------------------------------------------------------- calls


def test_outputs_are_written_in_place_and_checked(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    chain = robot.chain()
    q = robot.random_configuration(rng)
    T, J = np.empty((4, 4)), np.empty((6, 7))
    assert chain.fk(q, out=T) is T
    assert chain.jacobian(q, out=J) is J
    close(J, robot.jacobian(q), "in place")
    pose, jac = chain.kinematics(q, "local", pose=T, jacobian=J)
    assert pose is T and jac is J
    with pytest.raises(ShapeError, match=r"jacobian must be .* shape \(6, 7\)"):
        chain.jacobian(q, out=np.empty((6, 6)))
    with pytest.raises(ShapeError, match="C-contiguous"):
        chain.jacobian(q, out=np.empty((7, 6)).T)
    for call in (chain.fk, chain.jacobian, lambda q: chain.pose_error(q, np.eye(4))):
        with pytest.raises(NonFiniteError, match="q contains NaN or infinity"):
            call(np.array([0.0, 1.0, np.inf, 0.0, 0.0, 0.0, 0.0]))
        with pytest.raises(NonFiniteError, match="q contains NaN or infinity"):
            call([0.0, 1.0, 0.0, 0.0, 0.0, 0.0, np.nan])
    with pytest.raises(ShapeError, match="T_target"):
        chain.pose_error(q, np.eye(3), validate=False)
    with pytest.raises(ShapeError, match="q"):
        chain.fk(np.zeros(6))
    with pytest.raises(ValueError, match="reference must be 'world' or 'local'"):
        chain.kinematics(q, "base")  # type: ignore[arg-type]
    assert robot.chain() is chain  # cached
    for copied in (pickle.loads(pickle.dumps(robot)).chain(), copy.deepcopy(chain)):
        assert not copied.arrays[0].flags.writeable
        close(copied.jacobian(q), robot.jacobian(q), "copy")


def test_the_raw_kernels_take_the_chain_arrays(rng: np.random.Generator) -> None:
    """The hot-path form: kernel entry points with SerialChain.arrays, nothing checked."""
    robot = rr.models.iiwa14()
    chain = robot.chain()
    q = robot.random_configuration(rng)
    T, J, e = np.empty((4, 4)), np.empty((6, 7)), np.empty(6)
    chain.kernel("jacobian")(*chain.arrays, q, True, T, J)
    close(J, robot.jacobian(q, reference="local"), "local")
    target = robot.fk(robot.random_configuration(rng))
    assert chain.kernel("pose_error")(*chain.arrays, q, target, T, J, e)
    close(e, chain.pose_error(q, target).error, "pose error")
    # Every entry of q is checked, also those of joints past the frame.
    q[6] = np.nan
    assert not chain.kernel("fk")(*chain.arrays, q, T)
    with pytest.raises(NonFiniteError):
        robot.chain("link2").jacobian(q)


def plain_python_kernels(monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    """A second copy of the kernel module loaded with the compile switch off, as
    ``REDRES_DISABLE_JIT=1`` would: every kernel is the plain Python it is written as."""
    monkeypatch.setattr(_jit, "_ENABLED", False)
    source = SRC / "redres" / "robot" / "_chain_kernels.py"
    spec = importlib.util.spec_from_file_location("redres.robot._plain_chain_kernels", source)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_kernels_as_plain_python_give_the_same_results(
    monkeypatch: pytest.MonkeyPatch, rng: np.random.Generator
) -> None:
    plain = plain_python_kernels(monkeypatch)
    assert not hasattr(plain.jacobian, "py_func")  # not a numba dispatcher
    robots = [rr.models.panda()]
    robots.append(rr.Robot.from_dh(dh_links(rng, ["revolute", "prismatic", "revolute"]),
                                   "modified", tool=random_pose(rng)))  # fmt: skip
    for robot in robots:
        chain = robot.chain()
        q = 1.5 * robot.random_configuration(rng)
        target = robot.fk(robot.random_configuration(rng))
        T, J, e = np.empty((4, 4)), np.empty((6, robot.n)), np.empty(6)
        for local in (False, True):
            plain.jacobian(*chain.arrays, q, local, T, J)
            close(J, chain.jacobian(q, "local" if local else "world"), "plain Jacobian")
        plain.fk(*chain.arrays, q, T)
        close(T, chain.fk(q), "plain fk")
        plain.pose_error(*chain.arrays, q, target, T, J, e)
        close(e, chain.pose_error(q, target).error, "plain pose error")
