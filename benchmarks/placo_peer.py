"""PlaCo's side of the comparisons, run by ``peers.placo_run`` in PlaCo's own interpreter.

PlaCo (Rhoban's planning and control library, PyPI ``placo``) pins its own Pinocchio
(``pin==3.8.0`` through cmeel for placo 0.10.2), which cannot live beside redres'
Pinocchio 4 in one environment. So this script imports only NumPy and PlaCo: it reads one
job as JSON on standard input, builds PlaCo's ``KinematicsSolver`` on the URDF the job
names (the same Panda file every peer reads, ``peers.write_urdf``), and prints the result
as JSON on standard output.

Jobs (``"kind"``):

* ``"step"``: time one control step per configuration in ``"setups"`` at the same state:
  set the joints, ``update_kinematics``, ``solve(True)`` (the QP: a soft frame task,
  optionally a soft joints task toward ``"posture"``, joint-position and velocity limits
  when asked, with ``solver.dt``), read ``robot.state.q``. Each call timed alone, in
  ``"rounds"`` blocks of ``"calls"`` calls (or each block's mean, ``"per_call": false``),
  the setups interleaved in a shuffled order.
  Returns per setup the times (µs) and the ``q`` after one step.
* ``"loop"``: close the loop on a sequence of target poses (one per period, the pose one
  period ahead, as pink and mink track a moving target in quality.py) from ``"q0"``;
  returns the configuration at the start of each step and each step's time (µs).

* ``--serve`` (one job as the first line of standard input): time blocks of a setup on
  request (:func:`serve`), for a benchmark that interleaves PlaCo with its own contenders.

Run by hand: ``PLACO_PYTHON=... python benchmarks/step.py`` (the benchmark starts this);
``python placo_peer.py < job.json`` for one job.
"""

from __future__ import annotations

import json
import random
import sys
import time
from typing import Any

import numpy as np


def build(job: dict[str, Any], setup: dict[str, Any]) -> tuple[Any, Any, Any, Any]:
    """``(placo, robot, solver, frame task)`` for one setup of ``job``."""
    import placo

    robot = placo.RobotWrapper(job["urdf"], placo.Flags.ignore_collisions)
    for name, lo, hi, rate in zip(job["joints"], job["q_min"], job["q_max"], job["qd_max"]):
        robot.set_joint_limits(name, lo, hi)
        robot.set_velocity_limit(name, rate)
    solver = placo.KinematicsSolver(robot)
    solver.mask_fbase(True)
    solver.dt = job["dt"]
    solver.enable_joint_limits(bool(setup.get("joint_limits", False)))
    solver.enable_velocity_limits(bool(setup.get("velocity_limits", False)))
    target = np.asarray(job.get("target", np.eye(4).ravel()), dtype=float).reshape(4, 4)
    frame = solver.add_frame_task(job["tip"], target)
    frame.configure("frame", "soft", 1.0, 1.0)
    if setup.get("posture_weight"):
        posture = solver.add_joints_task()
        posture.set_joints(dict(zip(job["joints"], job["posture"])))
        posture.configure("posture", "soft", float(setup["posture_weight"]))
    if setup.get("regularization"):
        solver.add_regularization_task(float(setup["regularization"]))
    return placo, robot, solver, frame


def stepper(job: dict[str, Any], setup: dict[str, Any], q: np.ndarray) -> Any:
    """The timed call of one setup: joints <- q, kinematics, the QP, the new ``q``."""
    _, robot, solver, _ = build(job, setup)
    names = list(job["joints"])
    pairs = list(zip(names, q.tolist()))
    set_joint, update, solve = robot.set_joint, robot.update_kinematics, solver.solve

    def step() -> np.ndarray:
        for name, value in pairs:
            set_joint(name, value)
        update()
        solve(True)
        return np.array([robot.get_joint(name) for name in names])

    return step


def run_step(job: dict[str, Any]) -> dict[str, Any]:
    q = np.asarray(job["q"], dtype=float)
    steps = {key: stepper(job, setup, q) for key, setup in job["setups"].items()}
    after = {key: fn().tolist() for key, fn in steps.items()}
    for fn in steps.values():
        for _ in range(20):
            fn()
    times: dict[str, list[float]] = {key: [] for key in steps}
    clock, order = time.perf_counter_ns, list(steps)
    for _ in range(int(job["rounds"])):
        random.shuffle(order)
        for key in order:
            fn, out, calls = steps[key], times[key], int(job["calls"])
            if job.get("per_call", True):
                for _ in range(calls):
                    t0 = clock()
                    fn()
                    out.append((clock() - t0) / 1e3)
            else:  # the block's mean, as _common.interleaved times
                t0 = clock()
                for _ in range(calls):
                    fn()
                out.append((clock() - t0) / calls / 1e3)
    return {"times": times, "q_after": after}


def serve(job: dict[str, Any]) -> None:
    """Time blocks on request, so that the caller interleaves them with its own contenders:
    after a first line (the tip poses and each setup's ``q`` after one step), each input
    line ``KEY CALLS PER_CALL`` gets one line back, the per-call times (µs) of one block of
    that setup (each call alone if PER_CALL is 1, else the block's mean); ``quit`` ends."""
    q = np.asarray(job["q"], dtype=float)
    steps = {key: stepper(job, setup, q) for key, setup in job["setups"].items()}
    first = {"fk": tip_poses(job), "q_after": {key: fn().tolist() for key, fn in steps.items()}}
    for fn in steps.values():
        for _ in range(20):
            fn()
    print(json.dumps(first), flush=True)
    clock = time.perf_counter_ns
    for line in sys.stdin:
        if line.strip() == "quit":
            return
        key, calls, per_call = line.split()
        fn, count, out = steps[key], int(calls), []
        if per_call == "1":
            for _ in range(count):
                t0 = clock()
                fn()
                out.append((clock() - t0) / 1e3)
        else:
            t0 = clock()
            for _ in range(count):
                fn()
            out.append((clock() - t0) / count / 1e3)
        print(json.dumps(out), flush=True)


def run_loop(job: dict[str, Any]) -> dict[str, Any]:
    _, robot, solver, frame = build(job, job["setup"])
    names = list(job["joints"])
    targets = np.asarray(job["targets"], dtype=float).reshape(-1, 4, 4)
    q = np.asarray(job["q0"], dtype=float)
    Q, times = np.empty((len(targets), q.size)), np.empty(len(targets))
    clock = time.perf_counter_ns
    for k, target in enumerate(targets):
        Q[k] = q
        t0 = clock()
        for name, value in zip(names, q.tolist()):
            robot.set_joint(name, value)
        robot.update_kinematics()
        frame.T_world_frame = target
        solver.solve(True)
        q = np.array([robot.get_joint(name) for name in names])
        times[k] = (clock() - t0) / 1e3
    return {"q": Q.tolist(), "times": times.tolist()}


def tip_poses(job: dict[str, Any]) -> list[list[float]]:
    """The tip's pose (16, row-major) at each configuration of ``job["check_q"]``: the
    caller compares them with redres' before it compares anything else."""
    _, robot, _, _ = build(job, {})
    out = []
    for q in job.get("check_q", []):
        for name, value in zip(job["joints"], q):
            robot.set_joint(name, float(value))
        robot.update_kinematics()
        out.append(np.asarray(robot.get_T_world_frame(job["tip"])).ravel().tolist())
    return out


def main() -> int:
    if sys.argv[1:] == ["--serve"]:
        serve(json.loads(sys.stdin.readline()))
        return 0
    job = json.load(sys.stdin)
    from importlib.metadata import version

    result: dict[str, Any] = {"placo": version("placo")}
    result["fk"] = tip_poses(job)
    result.update(run_step(job) if job["kind"] == "step" else run_loop(job))
    json.dump(result, sys.stdout)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
