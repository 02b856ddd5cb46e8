"""Quality on a joint-limit problem: the Panda circle that drives plain pseudo-inverse control
into a joint limit, tracked by each library's best equivalent configuration.

The scenario is ``redres.scenarios.spec.builtin("panda_joint_limit_circle")``: the TCP on a 10 cm
circle, 2.5 s per turn, four turns (10 s at 1 kHz, 10,000 steps), from the same start
configuration. Every contender closes the same loop at dt = 1 ms and every figure below is
computed here, with Pinocchio forward kinematics (robot.fk), from the configuration at the start of
each step: the largest TCP position and orientation errors against the reference, the
largest position error after the first 0.25 s (the schemes with acceleration limits start
from rest on a circle that starts at full speed), and the smallest joint-limit margin
(negative: a joint went past its limit). Median wall time per step of the loop body.

* redres through ``rr.run`` (CLIK, gain 50/s with the reference twist as feed-forward,
  joint velocities scaled down uniformly to their limits): ``pinv`` (the minimum-norm
  solution, Whitney 1969), gradient projection of the joint-limit cost (gain 5), weighted
  least norm, and, when present, ``QPScheme`` and ``SNSScheme`` with the same cost (hard
  position, velocity and acceleration limits) — the scenario's settings; and gradient
  projection tuned as pink and mink are below: gain K = 1/dt (a dead-beat loop, as their
  gain-1 tasks) and null-space gain 50.
* KDL ``ChainIkSolverVel_pinv_nso``: the same loop, null-space motion toward mid-range
  with weights 2/range² and alpha 5. KDL normalises its null-space step so that the cost
  ``g = ½ Σ wᵢ (qᵢ − q̄ᵢ)²`` decays as ``ġ = −2α g`` (orocos_kdl,
  chainiksolvervel_pinv_nso.cpp): the same direction as redres' gradient projection, a
  larger, configuration-dependent magnitude.
* robotics-toolbox: the same loop with ``ets.jacob0``, ``p_servo`` (angle-axis error) and
  ``numpy.linalg.pinv`` plus the projected joint-limit gradient — its resolved-rate
  examples with a null-space term; it has no rate-control API of its own.
* pink and mink ``solve_ik``: a frame task whose target is the reference pose one period
  ahead, gain 1 (their tasks take no feed-forward twist; this is how they track moving
  targets), a posture task toward mid-range (cost 1e-3, gain 1e-2) and their
  configuration and velocity limits, solved by DAQP.
* PlaCo ``KinematicsSolver``: the same one-period-ahead frame target (its frame task has
  no gain: the whole error per step), a joints task toward mid-range (weight 1e-6, the
  square of the posture cost: PlaCo weighs squared residuals, and this task has no gain
  either), its joint-position and velocity limits with ``solver.dt`` = 1 ms; run in its
  own interpreter (``PLACO_PYTHON``: it pins its own Pinocchio), which times each step
  there.

Run: ``python benchmarks/quality.py``; prints Markdown.
"""

from __future__ import annotations

import argparse
import json
import math
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
from redres.objectives import JointLimitObjective
from redres.resolution import (
    GradientProjectionScheme,
    PseudoInverseScheme,
    WeightedLeastNormScheme,
)
from redres.scenarios.spec import builtin

DT, GAIN, K_NULL, SETTLE = 1e-3, 50.0, 5.0, 0.25
POSTURE_COST, POSTURE_GAIN = 1e-3, 1e-2
TUNED_GAIN, TUNED_NULL_GAIN = 1.0 / DT, 50.0  # dead-beat loop, stronger null-space pull
#: step(q, k) -> q after one period; k is the step index (time k·dt)
Loop = Callable[[np.ndarray, int], np.ndarray]


def redres_schemes() -> dict[str, tuple[Any, float]]:
    """label -> (scheme, CLIK gain K in 1/s)."""
    limits = JointLimitObjective
    found: dict[str, tuple[Any, float]] = {
        "redres pinv (minimum norm, Whitney 1969)": (PseudoInverseScheme(), GAIN),
        "redres gradient projection (joint limits)": (
            GradientProjectionScheme([limits()], k_null=K_NULL), GAIN),
        "redres weighted least norm": (WeightedLeastNormScheme(), GAIN),
    }  # fmt: skip
    for cls in ("QPScheme", "SNSScheme"):
        try:
            scheme_cls = getattr(__import__("redres.resolution", fromlist=[cls]), cls)
            scheme = scheme_cls(DT, objectives=[limits()], k_null=K_NULL)
            found[f"redres {cls} (hard limits + joint-limit cost)"] = (scheme, GAIN)
        except (ImportError, AttributeError) as exc:
            peers.note(f"redres {cls} skipped: {exc}")
    tuned = GradientProjectionScheme([limits()], k_null=TUNED_NULL_GAIN)
    found["redres gradient projection, K = 1/dt, k = 50 (tuned like pink/mink)"] = (
        tuned, TUNED_GAIN)  # fmt: skip
    return found


def clik(robot: rr.Robot, rate: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
         pose: Callable[[np.ndarray], np.ndarray], trajectory: Any) -> Loop:  # fmt: skip
    """The loop of ``rr.run`` around a peer's rate solver ``rate(q, T_now, twist_cmd)``."""

    def step(q: np.ndarray, k: int) -> np.ndarray:
        sample = trajectory.sample(k * DT)
        T = pose(q)
        e = np.concatenate([sample.pose[:3, 3] - T[:3, 3],
                            pin.log3(sample.pose[:3, :3] @ T[:3, :3].T)])  # fmt: skip
        qd = rate(q, T, sample.twist + GAIN * e)
        speed = float(np.max(np.abs(qd) / robot.qd_max))
        return q + (qd / speed if speed > 1.0 else qd) * DT

    return step


def kdl_loop(robot: rr.Robot, trajectory: Any) -> Loop | None:
    kdl = peers.import_kdl()
    if kdl is None:
        return None
    chain = peers.kdl_chain(kdl, "panda")
    fk, nso = kdl.ChainFkSolverPos_recursive(chain), kdl.ChainIkSolverVel_pinv_nso(chain)
    mid, weights = kdl.JntArray(7), kdl.JntArray(7)
    for i in range(7):
        mid[i] = float(robot.q_min[i] + robot.q_max[i]) / 2
        weights[i] = float(2.0 / (robot.q_max[i] - robot.q_min[i]) ** 2)
    nso.setOptPos(mid)
    nso.setWeights(weights)
    nso.setAlpha(K_NULL)
    jnt, qdot, frame, keep = kdl.JntArray(7), kdl.JntArray(7), kdl.Frame(), (chain, fk)

    def load(q: np.ndarray) -> None:
        for i, v in enumerate(q):
            jnt[i] = float(v)

    def pose(q: np.ndarray) -> np.ndarray:
        load(q)
        fk.JntToCart(jnt, frame)
        return peers.kdl_matrix(frame)

    def rate(q: np.ndarray, T: np.ndarray, xd: np.ndarray) -> np.ndarray:
        twist = kdl.Twist(kdl.Vector(*xd[:3].tolist()), kdl.Vector(*xd[3:].tolist()))
        if nso.CartToJnt(jnt, twist, qdot) < 0:  # jnt holds q (set by pose)
            raise RuntimeError(f"KDL pinv_nso failed ({keep[0].getNrOfJoints()} joints)")
        return np.array([qdot[i] for i in range(7)])

    return clik(robot, rate, pose, trajectory)


def rtb_loop(robot: rr.Robot, trajectory: Any, tmp: Path) -> Loop | None:
    rtb = peers.import_rtb()
    if rtb is None:
        return None
    ets = peers.rtb_robot(rtb, peers.write_urdf("panda", tmp)).ets(end=peers.TIP_LINK["panda"])
    mid, eye = (robot.q_min + robot.q_max) / 2, np.eye(7)
    scale = 2.0 / (robot.q_max - robot.q_min) ** 2

    def step(q: np.ndarray, k: int) -> np.ndarray:
        sample = trajectory.sample(k * DT)
        v, _ = rtb.p_servo(ets.eval(q), sample.pose, GAIN, method="angle-axis")
        J = ets.jacob0(q)
        J_pinv = np.linalg.pinv(J)
        qd = J_pinv @ (sample.twist + v) + (eye - J_pinv @ J) @ (-K_NULL * scale * (q - mid))
        speed = float(np.max(np.abs(qd) / robot.qd_max))
        return q + (qd / speed if speed > 1.0 else qd) * DT

    return step


def pink_loop(robot: rr.Robot, trajectory: Any) -> Loop | None:
    found = peers.import_pink()
    if found is None:
        return None
    pink, tasks = found
    model = pin.Model(robot.model)
    configuration = pink.Configuration(model, model.createData(), robot.neutral())
    frame = tasks.FrameTask("tcp", position_cost=1.0, orientation_cost=1.0, gain=1.0)
    posture = tasks.PostureTask(cost=POSTURE_COST, gain=POSTURE_GAIN)
    posture.set_target((robot.q_min + robot.q_max) / 2)

    def step(q: np.ndarray, k: int) -> np.ndarray:
        ahead = trajectory.sample((k + 1) * DT).pose
        frame.set_target(pin.SE3(ahead[:3, :3], ahead[:3, 3]))
        configuration.update(q)
        v = pink.solve_ik(configuration, [frame, posture], DT, "daqp", damping=1e-12)
        return q + v * DT

    return step


def mink_loop(robot: rr.Robot, trajectory: Any) -> Loop | None:
    found = peers.import_mink()
    if found is None:
        return None
    mink, mujoco = found
    model = peers.mujoco_model(mujoco, "panda")
    configuration = mink.Configuration(model)
    frame = mink.FrameTask("panda_hand_tcp", "body", position_cost=1.0, orientation_cost=1.0)
    posture = mink.PostureTask(model, cost=POSTURE_COST, gain=POSTURE_GAIN)
    posture.set_target((robot.q_min + robot.q_max) / 2)
    names = [model.joint(i).name for i in range(model.njnt)]
    limits = [mink.ConfigurationLimit(model),
              mink.VelocityLimit(model, dict(zip(names, robot.qd_max.tolist())))]  # fmt: skip

    def step(q: np.ndarray, k: int) -> np.ndarray:
        frame.set_target(mink.SE3.from_matrix(trajectory.sample((k + 1) * DT).pose))
        configuration.update(q)
        v = mink.solve_ik(configuration, [frame, posture], DT, "daqp", damping=1e-12,
                          limits=limits)  # fmt: skip
        return q + v * DT

    return step


def placo_loop(robot: rr.Robot, trajectory: Any, q0: np.ndarray, steps: int,
               tmp: Path) -> tuple[np.ndarray, np.ndarray] | None:  # fmt: skip
    """PlaCo's closed loop in its own process: configurations and step times (µs)."""
    targets = np.array([trajectory.sample((k + 1) * DT).pose.ravel() for k in range(steps)])
    setup = {"posture_weight": POSTURE_COST**2, "joint_limits": True, "velocity_limits": True}
    job = peers.placo_job("panda", "loop", tmp, q0=q0, targets=targets, dt=DT,
                          posture=(robot.q_min + robot.q_max) / 2, setup=setup)  # fmt: skip
    result = peers.placo_run("panda", job)
    if result is None:
        return None
    return np.asarray(result["q"]), np.asarray(result["times"])


def simulate(loop: Loop, q0: np.ndarray, steps: int, label: str) -> tuple[np.ndarray, np.ndarray]:
    """Configurations at the start of each step, and each step's wall time (µs)."""
    Q, times, q = np.empty((steps, q0.size)), np.empty(steps), q0.copy()
    clock = time.perf_counter_ns
    for k in tqdm(range(steps), desc=f"circle {label}", leave=False, mininterval=0.5):
        Q[k] = q
        t0 = clock()
        q = loop(q, k)
        times[k] = (clock() - t0) / 1e3
    return Q, times


def metrics(robot: rr.Robot, trajectory: Any, Q: np.ndarray) -> tuple[float, float, float, float]:
    """Max position error, max after SETTLE, max orientation error, min joint-limit margin."""
    pos, rot = np.empty(len(Q)), np.empty(len(Q))
    for k, q in enumerate(Q):
        ref, T = trajectory.sample(k * DT).pose, robot.fk(q)
        pos[k] = np.linalg.norm(ref[:3, 3] - T[:3, 3])
        chord = float(np.linalg.norm(ref[:3, :3] - T[:3, :3])) / (2.0 * math.sqrt(2.0))
        rot[k] = 2.0 * math.asin(min(chord, 1.0))
    margin = float(min(robot.joint_limit_margin(q).min() for q in Q))
    return float(pos.max()), float(pos[round(SETTLE / DT) :].max()), float(rot.max()), margin


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    scenario = builtin("panda_joint_limit_circle")
    robot, trajectory, q0 = scenario.robot, scenario.trajectory, scenario.q0
    steps = round(trajectory.duration / DT)
    runs: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for label, (scheme, gain) in redres_schemes().items():
        log = rr.run(robot, scenario.task(), trajectory, scheme, dt=DT, q0=q0, gain=gain,
                     label=label, progress=False)  # fmt: skip
        runs[label] = (log.q, log.step_time_ns / 1e3)
    with TemporaryDirectory() as tmp:
        peers.check_same_robot("panda", Path(tmp))
        loops = {
            "KDL ChainIkSolverVel_pinv_nso (mid-range)": kdl_loop(robot, trajectory),
            "robotics-toolbox jacob0 + pinv + null-space gradient": rtb_loop(
                robot, trajectory, Path(tmp)
            ),
            "pink solve_ik (frame + posture, limits)": pink_loop(robot, trajectory),
            "mink solve_ik (frame + posture, limits)": mink_loop(robot, trajectory),
        }
        for label, loop in loops.items():
            if loop is not None:
                runs[label] = simulate(loop, q0, steps, label)
        placo = placo_loop(robot, trajectory, q0, steps, Path(tmp))
        if placo is not None:
            runs["PlaCo KinematicsSolver (frame + joints task, limits; own process)"] = placo
    rows = []
    for label, (Q, times) in runs.items():
        pos, settled, rot, margin = metrics(robot, trajectory, Q)
        rows.append({"label": label, "max_position_mm": pos * 1e3, "settled_mm": settled * 1e3,
                     "max_orientation_mrad": rot * 1e3, "min_margin_rad": margin,
                     "step_us": float(np.median(times))})  # fmt: skip
    print(f"{scenario.description}; {steps} steps of {DT * 1e3:g} ms.\n")
    cells = [[r["label"], f"{r['max_position_mm']:.4f}", f"{r['settled_mm']:.4f}",
              f"{r['max_orientation_mrad']:.3f}", f"{r['min_margin_rad']:+.3f}",
              f"{r['step_us']:.1f}"] for r in rows]  # fmt: skip
    print(table(["library and configuration", "max position error mm",
                 f"max after {SETTLE:g} s mm", "max orientation error mrad",
                 "min joint-limit margin rad", "median µs per step"], cells))  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
