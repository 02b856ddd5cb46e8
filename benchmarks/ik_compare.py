"""Position inverse kinematics, redres next to its peers, on the same random reachable targets.

For each arm (Panda to its TCP, iiwa 14 to its flange), ``--targets`` configurations are
drawn uniformly within the joint limits (seeded) and their tip poses are the targets; each
library is verified to model the same arm first (tip poses equal to 1e-9 at random
configurations, else the run aborts). Every library gets the same harness:

* attempt 1 starts at the arm's neutral configuration; when an attempt ends without a
  solution, the next starts at a configuration drawn uniformly within the limits by a
  generator seeded with ``(seed, target index)`` — the same starts for every library;
* a success is checked here, never taken from the library's flag: redres forward
  kinematics of the returned configuration within 1e-6 m and 1e-5 rad (rotation angle from
  ``‖R − R_d‖_F``) and every joint within its limits (zero tolerance), found within the
  time limit (``--limit``, default 0.5 s, wall clock, all attempts included);
* each attempt uses the library's own iteration cap, and its stopping tolerance is set
  tight enough that meeting it meets ours:

  - redres ``ik(..., q0=start, max_restarts=0)`` (100 iterations, stall detection);
  - redres with its own restarts, as a user calls it: ``ik(..., q0=start, seed=k,
    timeout_s=time left)`` (restarts from its own seeded draws, inside the budget);
  - redres without the closed form (``analytic=False``: the iteration alone; the two rows
    above use the closed form first on these arms, :mod:`redres.ik.closed`);
  - TRAC-IK (``pytracik``, the C++ library: KDL Newton and SQP in two threads, random
    restarts inside its own timeout, set to the time limit), ``Speed``, ``epsilon=1e-7``;
  - robotics-toolbox ``ik_LM`` (Levenberg–Marquardt, Chan's damping, C++), ``ilimit=30``,
    one search per attempt, ``tol=1e-13`` on ½‖e‖², its joint-limit check on;
  - KDL ``ChainIkSolverPos_NR_JL`` (Newton–Raphson on ``ChainIkSolverVel_pinv``, joints
    clipped to limits), ``maxiter=100``, ``eps=1e-7`` per twist component;
  - ikpy ``inverse_kinematics`` (SciPy ``least_squares`` within bounds, full orientation),
    ``tol=1e-12``;
  - pink and mink ``solve_ik`` iterated to convergence: one frame task, ``dt = 1``, gain 1
    (Gauss–Newton steps), their configuration limits (and pink's velocity limits), DAQP,
    up to 100 iterations per attempt.

Times are per target, all attempts included, failures at their elapsed time.

The default time limit is the TRAC-IK protocol's 5 ms per target (Beeson & Ames,
"TRAC-IK", Humanoids 2015).

Run: ``python benchmarks/ik_compare.py [--targets 1000 | --quick] [--seed 7] [--limit 0.005]
[--libraries redres KDL ...]`` (``--libraries``: substrings of the rows to run; ``--quick``:
100 targets).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
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
from _common import machine, table

import redres as rr
from redres.ik import ik

TOL_POSITION, TOL_ORIENTATION = 1e-6, 1e-5
MAX_QP_ITERATIONS = 100
#: attempt(T, start, seconds left) -> configuration (n,)
Attempt = Callable[[np.ndarray, np.ndarray, float], np.ndarray]


def solved(robot: rr.Robot, frame: str, q: np.ndarray, T: np.ndarray) -> bool:
    """Our check of a solution: Pinocchio forward kinematics (robot.fk) and the joint limits."""
    if not (np.all(np.isfinite(q)) and robot.within_limits(q)):
        return False
    F = robot.fk(q, frame)
    if np.linalg.norm(F[:3, 3] - T[:3, 3]) > TOL_POSITION:
        return False
    chord = float(np.linalg.norm(F[:3, :3] - T[:3, :3])) / (2.0 * math.sqrt(2.0))
    return 2.0 * math.asin(min(chord, 1.0)) <= TOL_ORIENTATION


def redres_attempt(name: str, robot: rr.Robot, analytic: bool = True) -> Attempt:
    frame = peers.TIP_FRAME[name]

    def attempt(T: np.ndarray, start: np.ndarray, left: float) -> np.ndarray:
        return ik(robot, T, frame, q0=start, max_restarts=0, timeout_s=max(left, 1e-6),
                  analytic=analytic).q  # fmt: skip

    return attempt


def redres_own_attempt(name: str, robot: rr.Robot) -> Attempt:
    frame = peers.TIP_FRAME[name]
    calls = [0]

    def attempt(T: np.ndarray, start: np.ndarray, left: float) -> np.ndarray:
        calls[0] += 1
        return ik(robot, T, frame, q0=start, seed=calls[0], timeout_s=max(left, 1e-6)).q

    return attempt


def tracik_attempt(name: str, robot: rr.Robot, tmp: Path, limit: float) -> Attempt | None:
    try:
        import pytracik
    except ImportError:
        peers.note("TRAC-IK (pip install pytracik) is not installed: skipped")
        return None
    path = peers.write_urdf(name, tmp)
    text = path.read_text()
    children = set(re.findall(r"<child\s+link=\"([^\"]+)\"", text))
    base = next(x for x in re.findall(r"<link\s+name=\"([^\"]+)\"", text) if x not in children)
    solver = pytracik.TRAC_IK(base, peers.TIP_LINK[name], text, limit, 1e-7,
                              pytracik.SolveType.Speed)  # fmt: skip
    pytracik.set_joint_limits(solver, robot.q_min.tolist(), robot.q_max.tolist())

    def attempt(T: np.ndarray, start: np.ndarray, left: float) -> np.ndarray:
        quat = pin.Quaternion(T[:3, :3])
        r = pytracik.ik(solver, start, T[0, 3], T[1, 3], T[2, 3], quat.x, quat.y, quat.z, quat.w)
        return np.asarray(r[1:]) if r[0] >= 0 else start

    return attempt


def rtb_attempt(name: str, robot: rr.Robot, tmp: Path) -> Attempt | None:
    rtb = peers.import_rtb()
    if rtb is None:
        return None
    ets = peers.rtb_robot(rtb, peers.write_urdf(name, tmp)).ets(end=peers.TIP_LINK[name])

    def attempt(T: np.ndarray, start: np.ndarray, left: float) -> np.ndarray:
        return np.asarray(ets.ik_LM(T, q0=start, ilimit=30, slimit=1, tol=1e-13)[0])

    return attempt


def kdl_attempt(name: str, robot: rr.Robot) -> Attempt | None:
    kdl = peers.import_kdl()
    if kdl is None:
        return None
    chain = peers.kdl_chain(kdl, name)
    q_min, q_max, seed, out = (kdl.JntArray(robot.n) for _ in range(4))
    for i in range(robot.n):
        q_min[i], q_max[i] = float(robot.q_min[i]), float(robot.q_max[i])
    fk = kdl.ChainFkSolverPos_recursive(chain)
    vel = kdl.ChainIkSolverVel_pinv(chain)
    solver = kdl.ChainIkSolverPos_NR_JL(chain, q_min, q_max, fk, vel, 100, 1e-7)
    keep = (chain, fk, vel)  # KDL solvers hold bare references

    def attempt(T: np.ndarray, start: np.ndarray, left: float) -> np.ndarray:
        goal = kdl.Frame(kdl.Rotation(*T[:3, :3].ravel().tolist()), kdl.Vector(*T[:3, 3].tolist()))
        for i, v in enumerate(start):
            seed[i] = float(v)
        solver.CartToJnt(seed, goal, out)
        _ = keep
        return np.array([out[i] for i in range(robot.n)])

    return attempt


def ikpy_attempt(name: str, robot: rr.Robot, tmp: Path) -> Attempt | None:
    found = peers.import_ikpy()
    if found is None:
        return None
    chain, mask = peers.ikpy_chain(found, name, peers.write_urdf(name, tmp))

    def attempt(T: np.ndarray, start: np.ndarray, left: float) -> np.ndarray:
        full = np.zeros(len(mask))
        full[mask] = start
        sol = chain.inverse_kinematics(
            T[:3, 3], T[:3, :3], orientation_mode="all", initial_position=full, tol=1e-12
        )
        return np.asarray(sol)[mask]

    return attempt


def iterate(check: Callable[[np.ndarray], bool], update: Callable[[np.ndarray], None],
            step: Callable[[], np.ndarray], start: np.ndarray, left: float,
            errors: tuple[type[Exception], ...]) -> np.ndarray:  # fmt: skip
    """Loop a differential solver (dt = 1) until ``check`` passes, 100 steps or time out.

    The library's own errors (an infeasible QP) end the attempt.
    """
    q, deadline, clock = start.copy(), time.perf_counter() + left, time.perf_counter
    for _ in range(MAX_QP_ITERATIONS):
        if check(q) or clock() > deadline:
            break
        update(q)
        try:
            q = step()
        except errors:
            break
    return q


def pink_attempt(name: str, robot: rr.Robot) -> Attempt | None:
    found = peers.import_pink()
    if found is None:
        return None
    pink, tasks = found
    model = pin.Model(robot.model)
    configuration = pink.Configuration(model, model.createData(), robot.neutral())
    task = tasks.FrameTask(peers.TIP_FRAME[name], position_cost=1.0, orientation_cost=1.0)
    frame = peers.TIP_FRAME[name]

    def step() -> np.ndarray:
        v = pink.solve_ik(configuration, [task], 1.0, "daqp", damping=1e-12)
        configuration.integrate_inplace(v, 1.0)
        return configuration.q.copy()

    def attempt(T: np.ndarray, start: np.ndarray, left: float) -> np.ndarray:
        task.set_target(pin.SE3(T[:3, :3], T[:3, 3]))
        return iterate(lambda q: solved(robot, frame, q, T), configuration.update, step,
                       start, left, (pink.exceptions.PinkError,))  # fmt: skip

    return attempt


def mink_attempt(name: str, robot: rr.Robot) -> Attempt | None:
    found = peers.import_mink()
    if found is None:
        return None
    mink, mujoco = found
    model = peers.mujoco_model(mujoco, name)
    configuration = mink.Configuration(model)
    task = mink.FrameTask(peers.TIP_LINK[name], "body", position_cost=1.0, orientation_cost=1.0)
    limits = [mink.ConfigurationLimit(model)]
    frame = peers.TIP_FRAME[name]

    def step() -> np.ndarray:
        v = mink.solve_ik(configuration, [task], 1.0, "daqp", damping=1e-12, limits=limits)
        configuration.integrate_inplace(v, 1.0)
        return configuration.q.copy()

    def attempt(T: np.ndarray, start: np.ndarray, left: float) -> np.ndarray:
        task.set_target(mink.SE3.from_matrix(T))
        return iterate(lambda q: solved(robot, frame, q, T), configuration.update, step,
                       start, left, (mink.exceptions.MinkError,))  # fmt: skip

    return attempt


def solve(attempt: Attempt, robot: rr.Robot, frame: str, T: np.ndarray,
          rng: np.random.Generator, limit: float) -> tuple[bool, float, int]:  # fmt: skip
    """The shared harness: (success, seconds, attempts) for one target."""
    clock = time.perf_counter
    t0, start, attempts = clock(), robot.neutral(), 0
    while True:
        q = attempt(T, start, limit - (clock() - t0))
        attempts += 1
        elapsed = clock() - t0
        if elapsed > limit:
            return False, elapsed, attempts
        if solved(robot, frame, q, T):
            return True, elapsed, attempts
        start = robot.random_configuration(rng)


def contenders(
    name: str, robot: rr.Robot, tmp: Path, limit: float, wanted: list[str] | None
) -> dict[str, Attempt]:
    makers: dict[str, Callable[[], Attempt | None]] = {
        "redres": lambda: redres_attempt(name, robot),
        "redres (own restarts)": lambda: redres_own_attempt(name, robot),
        "redres (iteration only)": lambda: redres_attempt(name, robot, analytic=False),
        "TRAC-IK (pytracik)": lambda: tracik_attempt(name, robot, tmp, limit),
        "robotics-toolbox ik_LM": lambda: rtb_attempt(name, robot, tmp),
        "KDL ChainIkSolverPos_NR_JL": lambda: kdl_attempt(name, robot),
        "ikpy": lambda: ikpy_attempt(name, robot, tmp),
        "pink (iterated)": lambda: pink_attempt(name, robot),
        "mink (iterated)": lambda: mink_attempt(name, robot),
    }
    chosen = [k for k in makers if wanted is None or any(w.lower() in k.lower() for w in wanted)]
    found = {k: makers[k]() for k in chosen}
    return {k: v for k, v in found.items() if v is not None}


def run_arm(
    name: str, count: int, seed: int, limit: float, tmp: Path, wanted: list[str] | None
) -> list[dict[str, Any]]:
    robot = rr.models.load(name)
    frame = peers.TIP_FRAME[name]
    rng = np.random.default_rng(seed)
    targets = [robot.fk(robot.random_configuration(rng), frame) for _ in range(count)]
    rows = []
    with peers.native_output_to_stderr():  # peers' parsers print warnings (TRAC-IK's URDF)
        peers.check_same_robot(name, tmp)
        chosen = contenders(name, robot, tmp, limit, wanted)
        for attempt in chosen.values():
            attempt(targets[0], robot.neutral(), limit)  # warm-up: imports, compiled kernels
    for label, attempt in chosen.items():
        ok, times, attempts = 0, [], []
        for k, T in enumerate(tqdm(targets, desc=f"IK {name} {label}", leave=False)):
            success, seconds, tries = solve(attempt, robot, frame, T,
                                            np.random.default_rng([seed, k]), limit)  # fmt: skip
            ok += success
            times.append(seconds)
            attempts.append(tries)
        ms = np.array(times) * 1e3
        rows.append({"arm": name, "library": label, "success_pct": 100.0 * ok / count,
                     "median_ms": float(np.median(ms)), "mean_ms": float(ms.mean()),
                     "p99_ms": float(np.percentile(ms, 99)),
                     "attempts": float(np.mean(attempts))})  # fmt: skip
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--targets", type=int, default=1000)
    parser.add_argument("--quick", action="store_true", help="100 targets (a smoke run)")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--limit", type=float, default=0.005, help="time limit per target, s")
    parser.add_argument("--libraries", nargs="+", help="substrings of the rows to run")
    parser.add_argument("--arms", nargs="+", default=list(peers.ARMS))
    parser.add_argument("--json", type=Path, help="also write the figures to this file")
    args = parser.parse_args()
    if args.quick:
        args.targets = 100
    warnings.simplefilter("ignore")  # rtb's and ikpy's deprecation notices
    # compiled before timing, not behind
    rr.warmup(["linalg", "chain", "ik", "analytic ik"], quiet=True)
    rows: list[dict[str, Any]] = []
    with TemporaryDirectory() as tmp:
        for name in args.arms:
            rows += run_arm(name, args.targets, args.seed, args.limit, Path(tmp), args.libraries)
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"{machine()}; load average at the end {load}")
    print(
        f"{args.targets} random reachable pose targets per arm (seed {args.seed}), tolerance "
        f"{TOL_POSITION:g} m and {TOL_ORIENTATION:g} rad checked with Pinocchio forward "
        f"kinematics, joint limits enforced, time limit {args.limit * 1e3:.0f} ms per target.\n"
    )
    headers = ["arm", "library", "success", "median ms", "mean ms", "p99 ms", "attempts (mean)"]
    cells = [[r["arm"], r["library"], f"{r['success_pct']:.1f} %", f"{r['median_ms']:.2f}",
              f"{r['mean_ms']:.2f}", f"{r['p99_ms']:.1f}", f"{r['attempts']:.2f}"]
             for r in rows]  # fmt: skip
    print(table(headers, cells))
    if args.json:
        args.json.write_text(json.dumps({"limit_s": args.limit, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
