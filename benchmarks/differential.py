"""One differential-kinematics step on the Panda and the iiwa 14: redres next to each peer.

Every timed call is a whole control step on the same arm, at the same configuration, toward
the same tip target (2 cm and 2° away): forward kinematics and Jacobian of the tip, the
pose error ``[p_d − p; log(R_d Rᵀ)]`` with gain 50/s, the joint velocity, the integration
``q + q̇ dt`` (dt = 1 ms). Four operations, each with the peers' comparable call:

* ``pinv``: minimum-norm step. redres ``PseudoInverseScheme()``; KDL
  ``ChainIkSolverVel_pinv``; robotics-toolbox ``ets.eval`` + ``ets.jacob0`` + ``p_servo``
  + ``numpy.linalg.pinv`` (its resolved-rate examples); pink / mink ``solve_ik`` with the
  frame task only, no limits, damping 1e-12 (a Tikhonov-regularised least-squares step).
* ``damped``: damped least squares, λ = 0.05. redres ``PseudoInverseScheme(damping=0.05)``;
  KDL ``ChainIkSolverVel_wdls`` (setLambda); rtb with ``Jᵀ(JJᵀ + λ²I)⁻¹`` in NumPy; pink /
  mink ``solve_ik(damping=λ²)`` (the same normal equations), no limits.
* ``secondary``: the step plus a joint-limit (mid-range) objective. redres
  ``GradientProjectionScheme([JointLimitObjective()])``; KDL ``ChainIkSolverVel_pinv_nso``
  toward mid-range (weights 1/range²); rtb ``pinv`` plus the projected gradient in NumPy;
  pink / mink a frame task plus a posture task toward mid-range (cost 1e-3), no limits.
* ``qp``: hard limits. redres ``QPScheme`` (position, velocity and acceleration bounds,
  the same objective; skipped with a note when the ``qp`` extra is absent); pink /
  mink frame + posture tasks with their configuration and velocity limits (solver DAQP).
  KDL and robotics-toolbox have no velocity-QP API.

PlaCo (``KinematicsSolver``: set the joints, ``update_kinematics``, ``solve(True)``, read
the new ``q``) does each operation with its soft frame task: ``pinv`` alone, ``damped``
with its regularization task of weight λ², ``secondary`` with a joints task toward
mid-range (weight 1e-6, the square of pink's and mink's posture cost 1e-3: PlaCo weighs
squared residuals), ``qp`` with that and its joint-position and velocity limits
(``solver.dt`` = 1 ms, redres' limits); it has no acceleration limits. Not comparable in
two ways: its frame task asks for the whole pose error per step (no gain: a dead-beat
step, as pink and mink with gain 1, where redres and KDL use gain 50/s), which changes
the answer, not the work; and it pins its own Pinocchio, so it runs in its own
interpreter (``PLACO_PYTHON``, ``peers.PlacoSteps``), which times its calls the same way
(each alone) in blocks requested in their turn among the shuffled contenders.

Two redres rows per operation: the step composed by hand from the public parts
(``FrameTask.compute``, ``Scheme.step``, integration), and ``Controller.step``, the
library's loop step (the fused kernel for a frame task; its frame front end and
``QPScheme`` for ``qp``). The ratio column uses the faster redres row; a third row,
``rate_step`` on arrays, shows the cost of the ``Scheme`` layer.

Timing: every call is timed alone (``perf_counter_ns``, ~0.1 µs of overhead in every
figure), in blocks of ``--calls`` calls per contender, the contenders in a new shuffled
order in each of ``--rounds`` rounds, so machine noise hits all alike. Median and p99
per step; the ratio is redres' median over the peer's (< 1: redres is faster).

Run: ``python benchmarks/differential.py [--rounds 60] [--calls 100]``; prints Markdown.
"""

from __future__ import annotations

import argparse
import functools
import json
import random
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from tempfile import TemporaryDirectory
from typing import Any

import numpy as np
import pinocchio as pin
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).parent))

import peers
from _common import table

import redres as rr
from redres.control import Controller
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme
from redres.tasks import FrameTask

DT, GAIN, DAMPING, K_NULL, POSTURE_COST = 1e-3, 50.0, 0.05, 5.0, 1e-3
OPERATIONS = ("pinv", "damped", "secondary", "qp")
Step = Callable[[], object]


def problem(name: str) -> tuple[rr.Robot, np.ndarray, np.ndarray]:
    """The arm at a seeded configuration inside its limits, a tip target 2 cm away."""
    robot = rr.models.load(name)
    q = robot.random_configuration(7, margin=0.3)
    target = robot.fk(q, peers.TIP_FRAME[name])
    target[:3, 3] += [0.02, -0.01, 0.01]
    target[:3, :3] = target[:3, :3] @ pin.exp3(np.array([0.02, 0.0, -0.03]))
    return robot, q, target


def redres_steps(name: str, robot: rr.Robot, q: np.ndarray, T: np.ndarray) -> dict[str, Step]:
    task = FrameTask(peers.TIP_FRAME[name])
    task.set_target(T)
    objective = JointLimitObjective()
    schemes: dict[str, Any] = {
        "pinv": PseudoInverseScheme(),
        "damped": PseudoInverseScheme(damping=DAMPING),
        "secondary": GradientProjectionScheme([objective], k_null=K_NULL),
    }
    try:
        from redres.resolution import QPScheme

        schemes["qp"] = QPScheme(DT, objectives=[objective], k_null=K_NULL)
    except ImportError as exc:  # the optional QP backend (the qp extra)
        peers.note(f"redres QP step skipped: {exc}")

    def make(scheme: Any) -> Step:
        def step() -> np.ndarray:
            state = task.compute(robot, q)
            return q + scheme.step(robot, q, state.jacobian, state.command(GAIN)).qd * DT

        return step

    return {op: make(s) for op, s in schemes.items()}


def redres_fused(name: str, robot: rr.Robot, q: np.ndarray, T: np.ndarray) -> dict[str, Step]:
    """The same steps through ``Controller.step`` (one Pinocchio call, one compiled
    kernel; the QP step with the kernel's frame front end and ``QPScheme``)."""
    frame = peers.TIP_FRAME[name]
    objective = JointLimitObjective()
    schemes: dict[str, Any] = {
        "pinv": PseudoInverseScheme(),
        "damped": PseudoInverseScheme(damping=DAMPING),
        "secondary": GradientProjectionScheme([objective], k_null=K_NULL),
    }
    try:
        from redres.resolution import QPScheme

        schemes["qp"] = QPScheme(DT, objectives=[objective], k_null=K_NULL)
    except ImportError:  # noted by redres_steps
        pass
    steps = {}
    for op, scheme in schemes.items():
        task = FrameTask(frame)
        task.set_target(T)
        controller = Controller(robot, task, scheme, gain=GAIN, dt=DT, limit_velocity=False)
        steps[op] = functools.partial(controller.step, q)
    return steps


def redres_bare(name: str, robot: rr.Robot, q: np.ndarray, T: np.ndarray) -> dict[str, Step]:
    """The same steps through ``redres.linalg.rate_step`` on arrays (no Scheme object)."""
    task = FrameTask(peers.TIP_FRAME[name])
    task.set_target(T)
    objective, rate_step = JointLimitObjective(), rr.linalg.rate_step

    def make(damping: float, secondary: bool) -> Step:
        def step() -> np.ndarray:
            state = task.compute(robot, q)
            grad = objective.gradient(robot, q) if secondary else None
            qd, _, _ = rate_step(state.jacobian, state.command(GAIN), grad, k_null=K_NULL,
                              damping=damping)  # fmt: skip
            return q + qd * DT

        return step

    return {"pinv": make(0.0, False), "damped": make(DAMPING, False), "secondary": make(0.0, True)}


def kdl_steps(name: str, robot: rr.Robot, q: np.ndarray, T: np.ndarray) -> dict[str, Step]:
    kdl = peers.import_kdl()
    if kdl is None:
        return {}
    chain = peers.kdl_chain(kdl, name)
    fk = kdl.ChainFkSolverPos_recursive(chain)
    pinv = kdl.ChainIkSolverVel_pinv(chain)
    wdls = kdl.ChainIkSolverVel_wdls(chain)
    wdls.setLambda(DAMPING)
    nso = kdl.ChainIkSolverVel_pinv_nso(chain)
    mid, weights = kdl.JntArray(7), kdl.JntArray(7)
    for i in range(7):
        mid[i] = float(robot.q_min[i] + robot.q_max[i]) / 2
        weights[i] = float(2.0 / (robot.q_max[i] - robot.q_min[i]) ** 2)
    nso.setOptPos(mid)
    nso.setWeights(weights)
    nso.setAlpha(K_NULL)
    goal = kdl.Frame(kdl.Rotation(*T[:3, :3].ravel().tolist()), kdl.Vector(*T[:3, 3].tolist()))
    jnt, qdot, pose = kdl.JntArray(7), kdl.JntArray(7), kdl.Frame()
    for i, v in enumerate(q):
        jnt[i] = float(v)
    keep = (chain, fk)  # KDL solvers hold bare references to the chain

    def make(solver: Any) -> Step:
        def step() -> list[float]:
            fk.JntToCart(jnt, pose)
            status = solver.CartToJnt(jnt, kdl.diff(pose, goal) * GAIN, qdot)
            if status < 0:
                raise RuntimeError(f"KDL velocity solver failed: {status} ({keep})")
            return [jnt[i] + qdot[i] * DT for i in range(7)]

        return step

    return {"pinv": make(pinv), "damped": make(wdls), "secondary": make(nso)}


def rtb_steps(name: str, robot: rr.Robot, q: np.ndarray, T: np.ndarray, tmp: Path) -> dict:
    rtb = peers.import_rtb()
    if rtb is None:
        return {}
    ets = peers.rtb_robot(rtb, peers.write_urdf(name, tmp)).ets(end=peers.TIP_LINK[name])
    eye6, eye7 = DAMPING**2 * np.eye(6), np.eye(7)
    mid, scale = (robot.q_min + robot.q_max) / 2, 2.0 / (robot.q_max - robot.q_min) ** 2
    p_servo, np_pinv, solve = rtb.p_servo, np.linalg.pinv, np.linalg.solve

    def pinv() -> np.ndarray:
        v, _ = p_servo(ets.eval(q), T, GAIN, method="angle-axis")
        return q + np_pinv(ets.jacob0(q)) @ v * DT

    def damped() -> np.ndarray:
        v, _ = p_servo(ets.eval(q), T, GAIN, method="angle-axis")
        J = ets.jacob0(q)
        return q + J.T @ solve(J @ J.T + eye6, v) * DT

    def secondary() -> np.ndarray:
        v, _ = p_servo(ets.eval(q), T, GAIN, method="angle-axis")
        J = ets.jacob0(q)
        J_pinv = np_pinv(J)
        null = (eye7 - J_pinv @ J) @ (-K_NULL * scale * (q - mid))
        return q + (J_pinv @ v + null) * DT

    return {"pinv": pinv, "damped": damped, "secondary": secondary}


def pink_steps(name: str, robot: rr.Robot, q: np.ndarray, T: np.ndarray) -> dict[str, Step]:
    found = peers.import_pink()
    if found is None:
        return {}
    pink, tasks = found
    model = pin.Model(robot.model)
    configuration = pink.Configuration(model, model.createData(), q.copy())
    frame = tasks.FrameTask(peers.TIP_FRAME[name], position_cost=1.0, orientation_cost=1.0)
    frame.gain = GAIN * DT  # the same closed-loop gain: Δq = J⁺(K dt e)
    frame.set_target(pin.SE3(T[:3, :3], T[:3, 3]))
    posture = tasks.PostureTask(cost=POSTURE_COST)
    posture.set_target((robot.q_min + robot.q_max) / 2)

    def make(task_list: list, damping: float, limits: list | None) -> Step:
        def step() -> np.ndarray:
            configuration.update(q)
            v = pink.solve_ik(configuration, task_list, DT, "daqp", damping=damping, limits=limits)
            return q + v * DT

        return step

    return {
        "pinv": make([frame], 1e-12, []),
        "damped": make([frame], DAMPING**2, []),
        "secondary": make([frame, posture], 1e-12, []),
        "qp": make([frame, posture], 1e-12, None),  # None: its configuration + velocity limits
    }


def mink_steps(name: str, robot: rr.Robot, q: np.ndarray, T: np.ndarray) -> dict[str, Step]:
    found = peers.import_mink()
    if found is None:
        return {}
    mink, mujoco = found
    model = peers.mujoco_model(mujoco, name)
    configuration = mink.Configuration(model)
    configuration.update(q.copy())
    frame = mink.FrameTask(peers.TIP_LINK[name], "body", position_cost=1.0, orientation_cost=1.0)
    frame.gain = GAIN * DT
    frame.set_target(mink.SE3.from_matrix(T))
    posture = mink.PostureTask(model, cost=POSTURE_COST)
    posture.set_target((robot.q_min + robot.q_max) / 2)
    names = [model.joint(i).name for i in range(model.njnt)]
    limits = [
        mink.ConfigurationLimit(model),
        mink.VelocityLimit(model, dict(zip(names, robot.qd_max.tolist()))),
    ]

    def make(task_list: list, damping: float, lims: list) -> Step:
        def step() -> np.ndarray:
            configuration.update(q)
            v = mink.solve_ik(configuration, task_list, DT, "daqp", damping=damping, limits=lims)
            return q + v * DT

        return step

    return {
        "pinv": make([frame], 1e-12, []),
        "damped": make([frame], DAMPING**2, []),
        "secondary": make([frame, posture], 1e-12, []),
        "qp": make([frame, posture], 1e-12, limits),
    }


def sample(
    contenders: dict[str, Step],
    rounds: int,
    calls: int,
    remote: Callable[[int], list[float]] | None = None,
) -> dict[str, np.ndarray]:
    """Per-call times (µs), contenders interleaved in a new random order every round;
    ``remote(calls)``: a block of PlaCo's calls timed in its process, its turn among them."""
    for fn in contenders.values():
        for _ in range(20):
            fn()
    out: dict[str, list[float]] = {k: [] for k in contenders}
    clock, order = time.perf_counter_ns, list(contenders)
    if remote is not None:
        out["PlaCo"] = []
        order.append("PlaCo")
    for _ in range(rounds):
        random.shuffle(order)
        for key in order:
            if key == "PlaCo" and remote is not None:
                out[key].extend(remote(calls))
                continue
            fn, times = contenders[key], out[key]
            for _ in range(calls):
                t0 = clock()
                fn()
                times.append((clock() - t0) / 1e3)
    return {k: np.asarray(v) for k, v in out.items()}


LABELS = {
    "redres-fused": "redres (Controller.step, compiled)",
    "redres": "redres (FrameTask + Scheme.step, composed)",
    "redres-bare": "redres (linalg.rate_step on arrays)",
    "KDL": "KDL (pinv / wdls / pinv_nso)",
    "robotics-toolbox": "robotics-toolbox (jacob0 + NumPy)",
    "pink": "pink solve_ik",
    "mink": "mink solve_ik",
    "PlaCo": "PlaCo KinematicsSolver (own process)",
}

#: PlaCo's setup of each operation (placo_peer.py's fields).
PLACO_SETUPS = {
    "pinv": {},
    "damped": {"regularization": DAMPING**2},
    "secondary": {"posture_weight": POSTURE_COST**2},
    "qp": {"posture_weight": POSTURE_COST**2, "joint_limits": True, "velocity_limits": True},
}


def placo_server(name: str, robot: rr.Robot, q: np.ndarray, T: np.ndarray, tmp: Path) -> Any:
    """PlaCo's four steps on the arm, in its own process (None without PlaCo)."""
    job = peers.placo_job(name, "step", tmp, q=q, target=T.ravel(), dt=DT,
                          posture=(robot.q_min + robot.q_max) / 2, setups=PLACO_SETUPS)  # fmt: skip
    return peers.placo_steps(name, job)


def measure(name: str, rounds: int, calls: int, tmp: Path) -> dict[str, dict[str, np.ndarray]]:
    """Per operation, per library, the per-call times on one arm."""
    robot, q, T = problem(name)
    by_library = {
        "redres-fused": redres_fused(name, robot, q, T),
        "redres": redres_steps(name, robot, q, T),
        "redres-bare": redres_bare(name, robot, q, T),
        "KDL": kdl_steps(name, robot, q, T),
        "robotics-toolbox": rtb_steps(name, robot, q, T, tmp),
        "pink": pink_steps(name, robot, q, T),
        "mink": mink_steps(name, robot, q, T),
    }
    server = placo_server(name, robot, q, T, tmp)
    results = {}
    for op in tqdm(OPERATIONS, desc=f"differential {name}", leave=False):
        contenders = {lib: steps[op] for lib, steps in by_library.items() if op in steps}
        remote = None if server is None else functools.partial(server.block, op, per_call=True)
        if "redres" in contenders:
            results[op] = sample(contenders, rounds, calls, remote)
    if server is not None:
        server.close()
    return results


def best_redres(times: dict[str, np.ndarray]) -> float:
    """The median of the faster of the two redres loop steps (not the bare ``rate_step``)."""
    return min(float(np.median(times[lib])) for lib in ("redres-fused", "redres") if lib in times)


def report(all_results: dict[str, dict[str, dict[str, np.ndarray]]]) -> str:
    """One Markdown table: rows (operation, library), columns per arm."""
    arms = list(all_results)
    headers = ["operation", "library"]
    for arm in arms:
        headers += [f"{arm} median µs", f"{arm} p99 µs", f"{arm} redres ÷ peer"]
    rows = []
    for op in OPERATIONS:
        for lib, label in LABELS.items():
            row, present = [op, label], False
            for arm in arms:
                times = all_results[arm].get(op, {})
                if lib not in times:
                    row += ["—", "—", "—"]
                    continue
                present = True
                med, base = float(np.median(times[lib])), best_redres(times)
                ratio = f"{base / med:.2f}"
                if lib.startswith("redres"):
                    ratio = "1" if med == base else "—"
                row += [f"{med:.1f}", f"{np.percentile(times[lib], 99):.1f}", ratio]
            if present:
                rows.append(row)
    return table(headers, rows)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=60)
    parser.add_argument("--calls", type=int, default=100)
    parser.add_argument("--arms", nargs="+", default=list(peers.ARMS))
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    args = parser.parse_args()
    warnings.simplefilter("ignore", DeprecationWarning)
    results = {}
    with TemporaryDirectory() as tmp:
        for name in args.arms:
            peers.check_same_robot(name, Path(tmp))
            results[name] = measure(name, args.rounds, args.calls, Path(tmp))
    print(report(results))
    if args.json:
        figures = {
            arm: {
                op: {
                    lib: {"median_us": float(np.median(t)), "p99_us": float(np.percentile(t, 99))}
                    for lib, t in times.items()
                }
                for op, times in ops.items()
            }
            for arm, ops in results.items()
        }
        args.json.write_text(json.dumps(figures, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
