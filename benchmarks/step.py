"""One control step on the Panda: redres next to pink, mink and KDL, in one run.

The redres step is a full closed-loop inverse-kinematics (CLIK) step through the public
API: forward kinematics and Jacobian of the TCP, the pose error (SO(3) log), the
damped inverse with Liégeois' joint-limit gradient projected into its null space,
velocity scaling and the integration ``q + q̇ dt`` — by ``Controller.step`` (its fused
path: one compiled kernel, the TCP's kinematics from the Panda's serial chain inside it),
and the same step composed from
``FrameTask``, the objective and ``rate_step`` (no velocity scaling). Peers do their
equivalent step on the same Panda:

* pink ``solve_ik`` and mink ``solve_ik``: a frame task plus a posture task, solved as a
  QP with joint-limit constraints (their only mode), then integration;
* KDL: forward kinematics, pose error, ``ChainIkSolverVel_wdls`` (weighted damped least
  squares), integration;
* PlaCo ``KinematicsSolver.solve`` (Rhoban; C++ over Pinocchio, QP by qpmad): set the
  joints, ``update_kinematics``, a soft frame task plus a soft joints task toward the
  neutral pose (weight 1e-6: pink's and mink's posture cost 1e-3, squared, as PlaCo weighs
  squared residuals) under its joint-position and velocity limits (``solver.dt`` = 1 ms,
  the same limits as redres'), read the new ``q``. PlaCo pins its own Pinocchio, so it
  runs in its own interpreter (``PLACO_PYTHON``, ``peers.PlacoSteps``), which times its
  blocks of 200 calls there, on request after each round of the others' (so that load
  hits it alike): its rows are marked "own process". Its frame task asks for the whole
  pose error in one step (no gain), as pink's and mink's with gain 1; the QP has the same
  size and constraints as the hard-limit rows' (less redres' acceleration limits).

The hard-limit rows do the same frame task under hard position, velocity and
acceleration limits: ``QPScheme`` (two small QPs) and ``SNSScheme`` (saturation in the
null space, no QP) in a ``Controller``: in one compiled call (front end, box, resolution,
integration; the QP's problems by compiled dense solvers), on the path that call replaced
(the kernel's front end, then the scheme's ``_step``; the QP through DAQP), and composed
from ``FrameTask`` and ``scheme.step``, each from the state it reaches after the warm-up
calls. On this
problem the command (gain 50 × a 2 cm, 2° error) exceeds the velocity limits, so every
solver saturates; a second table times the QP-type steps on a tracking problem (target
0.4 mm away: the command is feasible and met exactly). The path taken is printed.

Run: ``python benchmarks/step.py`` (or ``make bench``). Medians of interleaved batches;
ratios are peer time / redres time (> 1: redres faster).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from tempfile import TemporaryDirectory
from typing import Any

import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).parent))

from _common import interleaved, machine, median, table
from peers import (
    import_kdl,
    import_mink,
    import_pink,
    kdl_panda,
    mujoco_panda,
    placo_job,
    placo_steps,
)

import redres as rr
from redres.control import Controller
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, QPScheme, SNSScheme
from redres.tasks import FrameTask

DT = 1e-3
GAIN = 50.0
DAMPING = 0.05


def problem(scale: float = 1.0) -> tuple[rr.Robot, np.ndarray, np.ndarray]:
    """The Panda at a configuration inside its limits and a TCP target 2 cm away
    (``scale`` times the offset: 0.02 gives the tracking problem of the hard-limit rows)."""
    robot = rr.models.panda()
    q = robot.random_configuration(7, margin=0.3)
    target = robot.fk(q)
    target[:3, 3] += scale * np.array([0.02, -0.01, 0.01])
    target[:3, :3] = target[:3, :3] @ pin.exp3(scale * np.array([0.02, 0.0, -0.03]))
    return robot, q, target


def controller_step(robot: rr.Robot, q: np.ndarray, target: np.ndarray) -> Callable[[], object]:
    """The same step (plus velocity scaling) through ``Controller.step`` (fused path)."""
    task = FrameTask()
    scheme = GradientProjectionScheme([JointLimitObjective()], damping=DAMPING)
    controller = Controller(robot, task, scheme, gain=GAIN, dt=DT)
    if controller.path != "fused":
        raise AssertionError(f"expected the fused path; got {controller.path}")
    print(f"Controller.step: path {controller.path}, kinematics from {controller.kinematics}")
    task.set_target(target)
    step = controller.step
    return lambda: step(q)


def redres_step(robot: rr.Robot, q: np.ndarray, target: np.ndarray) -> Callable[[], object]:
    task = FrameTask()
    task.set_target(target)
    limits = JointLimitObjective()
    rate_step = rr.linalg.rate_step

    def step() -> np.ndarray:
        state = task.compute(robot, q)  # fk, Jacobian, pose error
        grad = limits.gradient(robot, q)
        qd, _, _ = rate_step(state.jacobian, state.command(GAIN), grad, k_null=1.0, damping=DAMPING)
        return q + qd * DT

    return step


def hard_limit_step(
    scheme: QPScheme | SNSScheme,
    robot: rr.Robot,
    q: np.ndarray,
    target: np.ndarray,
    one_call: bool = True,
) -> Callable[[], object]:
    """The controller: front end, the scheme inside the hard-limit box and integration in
    one compiled call (the QP's problems by the compiled dense solvers); with
    ``one_call=False`` the path it replaced: the compiled front end, then the scheme's
    ``_step`` (the QP's problems by DAQP)."""
    task = FrameTask()
    controller = Controller(robot, task, scheme, gain=GAIN, dt=DT)
    if not one_call:
        controller._box = False  # the frame path before the one-call step
    elif controller._box is False:
        raise AssertionError("expected the one-call hard-limit step")
    task.set_target(target)
    run = controller.step

    def step() -> np.ndarray:
        return run(q)

    step.last = lambda: controller.result  # type: ignore[attr-defined]
    return step


def composed_hard_limit_step(
    scheme: QPScheme | SNSScheme, robot: rr.Robot, q: np.ndarray, target: np.ndarray
) -> Callable[[], object]:
    """The same through the composed API: FrameTask, the scheme's step, integration."""
    task = FrameTask()
    task.set_target(target)

    def step() -> np.ndarray:
        state = task.compute(robot, q)
        result = scheme.step(robot, q, state.jacobian, state.command(GAIN))
        return q + result.qd * DT

    return step


def pink_step(robot: rr.Robot, q: np.ndarray, target: np.ndarray) -> Callable[[], object] | None:
    found = import_pink()
    if found is None:
        return None
    pink, tasks = found
    model = pin.Model(robot.model)
    configuration = pink.Configuration(model, model.createData(), q.copy())
    frame = tasks.FrameTask("tcp", position_cost=1.0, orientation_cost=1.0)
    frame.set_target(pin.SE3(target[:3, :3], target[:3, 3]))
    posture = tasks.PostureTask(cost=1e-3)
    posture.set_target(robot.neutral())
    solver = "daqp"

    def step() -> object:
        configuration.update(q)
        v = pink.solve_ik(configuration, [frame, posture], DT, solver=solver, damping=1e-6)
        return q + v * DT

    return step


def mink_step(robot: rr.Robot, q: np.ndarray, target: np.ndarray) -> Callable[[], object] | None:
    found = import_mink()
    if found is None:
        return None
    mink, mujoco = found
    model = mujoco_panda(mujoco)
    configuration = mink.Configuration(model)
    configuration.update(q.copy())
    frame = mink.FrameTask("panda_hand_tcp", "body", position_cost=1.0, orientation_cost=1.0)
    frame.set_target(
        mink.SE3.from_rotation_and_translation(mink.SO3.from_matrix(target[:3, :3]), target[:3, 3])
    )
    posture = mink.PostureTask(model, cost=1e-3)
    posture.set_target(robot.neutral())
    limits = [mink.ConfigurationLimit(model)]
    tcp = configuration.get_transform_frame_to_world("panda_hand_tcp", "body")
    if not np.allclose(tcp.translation(), robot.fk(q)[:3, 3], atol=1e-9):
        raise AssertionError("mink's Panda differs from redres'")

    def step() -> object:
        configuration.update(q)
        v = mink.solve_ik(configuration, [frame, posture], DT, "daqp", damping=1e-6, limits=limits)
        return q + v * DT

    return step


def kdl_step(robot: rr.Robot, q: np.ndarray, target: np.ndarray) -> Callable[[], object] | None:
    kdl = import_kdl()
    if kdl is None:
        return None
    chain = kdl_panda(kdl)
    fk = kdl.ChainFkSolverPos_recursive(chain)
    ik = kdl.ChainIkSolverVel_wdls(chain)
    ik.setLambda(DAMPING)
    goal = kdl.Frame(
        kdl.Rotation(*target[:3, :3].ravel().tolist()), kdl.Vector(*target[:3, 3].tolist())
    )
    jnt, qdot, pose = kdl.JntArray(7), kdl.JntArray(7), kdl.Frame()
    for i, v in enumerate(q):
        jnt[i] = float(v)

    def step(chain: object = chain) -> object:
        # The solvers hold a bare reference to the chain: keep it alive with the closure,
        # or KDL returns an error code and a zero velocity (a no-op that times nothing).
        fk.JntToCart(jnt, pose)
        twist = kdl.diff(pose, goal) * GAIN
        status = ik.CartToJnt(jnt, twist, qdot)
        if status < 0:
            raise RuntimeError(f"KDL ChainIkSolverVel_wdls failed with code {status}")
        return [jnt[i] + qdot[i] * DT for i in range(7)]

    return step


PLACO = "PlaCo KinematicsSolver (frame + posture QP, limits; own process)"


def placo_server(robot: rr.Robot, q: np.ndarray, target: np.ndarray, tmp: Path) -> Any:
    """PlaCo's step on the same Panda, state, target and limits, in its own process (None
    without PlaCo)."""
    setup = {"posture_weight": 1e-6, "joint_limits": True, "velocity_limits": True}
    job = placo_job("panda", "step", tmp, q=q, target=target.ravel(), dt=DT,
                    posture=robot.neutral(), setups={"qp": setup})  # fmt: skip
    server = placo_steps("panda", job)
    if server is not None:
        print(f"PlaCo: q after one step {np.round(server.q_after['qp'], 4)}")
    return server


def timed(contenders: dict[str, Callable[[], object]], server: Any) -> dict[str, np.ndarray]:
    """``_common.interleaved`` (5 rounds of 5 blocks of 200 calls), with PlaCo's blocks,
    timed in its process, after each round's."""
    times: dict[str, list[float]] = {name: [] for name in contenders}
    if server is not None:
        times[PLACO] = []
    for _ in range(5):
        for name, t in interleaved(contenders, rounds=1, batch=200, batches=5).items():
            times[name].extend(t.tolist())
        if server is not None:
            for _ in range(5):
                times[PLACO].extend(server.block("qp", 200, per_call=False))
    return {name: np.asarray(t) for name, t in times.items()}


def report(hard: dict[str, Callable[[], object]], times: dict[str, np.ndarray]) -> None:
    """The path of each hard-limit step and each QP peer's time over its own."""
    peers = ("pink solve_ik (frame + posture QP)", "mink solve_ik (frame + posture QP)", PLACO)
    for name, fn in hard.items():
        last = fn.last()  # type: ignore[attr-defined]
        ratios = [
            f"{peer.split()[0]} takes {median(times[peer]) / median(times[name]):.2f}x its time"
            for peer in peers
            if peer in times
        ]
        path = "exact" if last.feasible else "least violating / scaled"
        print(f"{name}: path {path}; {', '.join(ratios) or 'no QP peers installed'}")


def hard_limit_rows(
    robot: rr.Robot, q: np.ndarray, target: np.ndarray
) -> dict[str, Callable[[], object]]:
    """The hard-limit rows: each scheme in one compiled call, and on the path before it."""
    return {
        "redres QPScheme (hard limits, one compiled call)": hard_limit_step(
            QPScheme(dt=DT), robot, q, target
        ),
        "redres SNSScheme (hard limits, one compiled call)": hard_limit_step(
            SNSScheme(dt=DT), robot, q, target
        ),
        "redres QPScheme (front end + scheme step, DAQP)": hard_limit_step(
            QPScheme(dt=DT), robot, q, target, one_call=False
        ),
        "redres SNSScheme (front end + scheme step)": hard_limit_step(
            SNSScheme(dt=DT), robot, q, target, one_call=False
        ),
    }


def main() -> int:
    robot, q, target = problem()
    contenders = {
        "redres Controller.step (fused CLIK step)": controller_step(robot, q, target),
        "redres composed (FrameTask + gradient + rate_step)": redres_step(robot, q, target),
    }
    hard = hard_limit_rows(robot, q, target)
    contenders.update(hard)
    contenders["redres QPScheme composed (FrameTask + step)"] = composed_hard_limit_step(
        QPScheme(dt=DT), robot, q, target
    )
    contenders["redres SNSScheme composed (FrameTask + step)"] = composed_hard_limit_step(
        SNSScheme(dt=DT), robot, q, target
    )
    peers = {
        "pink solve_ik (frame + posture QP)": pink_step(robot, q, target),
        "mink solve_ik (frame + posture QP)": mink_step(robot, q, target),
        "KDL ChainIkSolverVel_wdls": kdl_step(robot, q, target),
    }
    contenders.update({k: v for k, v in peers.items() if v is not None})
    print(f"Panda control step, {machine()}")
    with TemporaryDirectory() as tmp:
        server = placo_server(robot, q, target, Path(tmp))
        times = timed(contenders, server)
    base = median(times[next(iter(contenders))])
    rows = []
    for name, t in times.items():
        med, p99 = median(t), float(np.percentile(t, 99))
        ratio = "1" if med == base else f"{med / base:.1f}x"
        rows.append([name, f"{med:.2f}" if med < 10 else f"{med:.1f}", f"{p99:.1f}", ratio])
    print(table(["step", "median µs", "p99 µs", "time / redres"], rows))
    report(hard, times)
    robot, q, target = problem(0.02)
    tracking = hard_limit_rows(robot, q, target)
    contenders = dict(tracking)
    for name, make in (("pink solve_ik (frame + posture QP)", pink_step),
                       ("mink solve_ik (frame + posture QP)", mink_step)):  # fmt: skip
        fn = make(robot, q, target)
        if fn is not None:
            contenders[name] = fn
    with TemporaryDirectory() as tmp:
        server2 = placo_server(robot, q, target, Path(tmp))
        times = timed(contenders, server2)
    for each in (server, server2):
        if each is not None:
            each.close()
    rows = [[name, f"{median(t):.1f}", f"{float(np.percentile(t, 99)):.1f}"]
            for name, t in times.items()]  # fmt: skip
    print("\nTracking problem (target 0.4 mm away)")
    print(table(["step", "median µs", "p99 µs"], rows))
    report(tracking, times)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
