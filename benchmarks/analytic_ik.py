"""Analytic IK at a given q7: redres ``at_q7`` next to its peers, on the same Panda poses.

``--poses`` configurations (default 1,000) are drawn uniformly within the Panda's joint
limits (seeded); their poses of the hand TCP (the flange, turned −π/4 about z, then
0.1034 m along z: Franka's published geometry, redres' default Panda tip) are the
targets, each solved at the configuration's own ``q7``. Every library is checked to model
the same arm and frame first (FK equal to 1e-9 at random configurations, else the run
aborts): geofik's frame ``E`` and frankik's ``fk`` are that TCP.

Per library, over the same poses: the median time of one call (the pose in the
library's own input form, prepared outside the timing: a 4x4 array for redres, lists
for geofik, the flange's pose for frankik, whose IK takes the flange although its FK
gives the TCP; solutions out; each call timed alone, rounds interleaved between the
libraries),
the time per solution (the median call over the mean solutions per pose: robust to the
machine's noise, as the median), the solutions per pose, the share of
poses whose original configuration is among the solutions (to 1e-6 rad), and the worst
FK error of any solution (redres' Pinocchio FK). redres' batch form is timed per pose
on all threads and on one, after every single call is timed (its FK errors computed in
the kernel, for every solution; a single call's on first access, not timed). The
iiwa14 (to its flange) is timed for redres alone, at ``q7`` and, an S-R-S arm, at the
arm angle of the configuration
(``rr.ik_all(robot, T, arm_angle=...)``'s single-pose path, ``at_arm_angle``: the
compiled closed form of ``redres.ik.srs``).

Peers: ``geofikpy`` (GeoFIK, ``franka_ik_q7``: up to 8 solutions), ``frankik``
(``ik_full``: up to 4, those within the Panda's limits), ``ik-geo`` (its Python package
builds 6R arms only: no model of a 7R arm at fixed q7, reported and not run),
``frantik`` (reported when it cannot be installed or imported).

Run: ``PYTHONPATH=src python benchmarks/analytic_ik.py [--poses N]``.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pinocchio as pin

import redres as rr
from redres import _compile
from redres.ik.analytic import at_q7, at_q7_batch
from redres.ik.solutions import at_arm_angle

#: (prepare: T -> the library's own input, solve: (input, q7) -> solutions (k, 7)).
Solver = tuple[Callable[[np.ndarray], Any], Callable[[Any, float], np.ndarray]]


def _peers(robot: rr.Robot) -> tuple[dict[str, Solver], dict[str, str]]:
    solvers: dict[str, Solver] = {}
    missing: dict[str, str] = {}
    try:
        import geofikpy

        def geofik(pose: tuple[list[float], list[float]], q7: float) -> np.ndarray:
            sols, n = geofikpy.franka_ik_q7(pose[0], pose[1], q7)
            return np.array(sols[:n]).reshape(n, 7)

        solvers["geofikpy"] = (lambda T: (T[:3, 3].tolist(), T[:3, :3].ravel().tolist()), geofik)
    except ImportError as exc:
        missing["geofikpy"] = f"import failed: {exc}"
    try:
        import frankik

        # frankik's fk gives the TCP but its IK takes the flange's pose: convert outside
        flange_tcp = np.linalg.inv(robot.fk(np.zeros(7), "flange")) @ robot.fk(np.zeros(7))
        tcp_flange = np.linalg.inv(flange_tcp)

        def frank(T: np.ndarray, q7: float) -> np.ndarray:
            sols = np.asarray(frankik.ik_full(T, None, q7, False))
            return sols[~np.isnan(sols).any(axis=1)]

        solvers["frankik"] = (lambda T: np.ascontiguousarray(T @ tcp_flange), frank)
    except ImportError as exc:
        missing["frankik"] = f"import failed: {exc}"
    try:
        import ik_geo  # noqa: F401

        missing["ik-geo"] = "installed; its Python package builds 6R arms only (no 7R or fixed-q7)"
    except ImportError as exc:
        missing["ik-geo"] = f"import failed: {exc}"
    try:
        import frantik  # noqa: F401

        missing["frantik"] = "imported, but no adapter written here"
    except ImportError as exc:
        missing["frantik"] = f"not installed (pip: its build failed; {exc})"
    return solvers, missing


def _check_frames(robot: rr.Robot, rng: np.random.Generator) -> None:
    import frankik
    import geofikpy

    for q in rng.uniform(robot.q_min, robot.q_max, size=(20, 7)):
        T = robot.fk(q)
        for name, other in (("geofik E", np.asarray(geofikpy.franka_fk(q.tolist(), "E"))),
                            ("frankik", np.asarray(frankik.fk(q)))):  # fmt: skip
            if np.abs(other - T).max() > 1e-9:
                raise SystemExit(f"{name} FK differs from redres' Panda TCP: not the same arm")


def _quality(robot: rr.Robot, q: np.ndarray, T: np.ndarray, sols: list[np.ndarray]) -> dict:
    found, worst_p, worst_r, nans = 0, 0.0, 0.0, 0
    for x, pose, s in zip(q, T, sols):
        finite = np.isfinite(s).all(axis=1)
        nans += int((~finite).sum())
        s = s[finite]
        if len(s):
            gap = np.abs((s - x + np.pi) % (2 * np.pi) - np.pi).max(axis=1)
            found += bool(gap.min() < 1e-6)
        for sol in s:
            F = robot.fk(sol)
            worst_p = max(worst_p, float(np.linalg.norm(F[:3, 3] - pose[:3, 3])))
            E = pose[:3, :3].T @ F[:3, :3]
            worst_r = max(worst_r, float(np.linalg.norm(pin.log3(E))))
    count = sum(len(s) for s in sols)
    return {"solutions": count / len(q), "found": found / len(q), "p": worst_p, "r": worst_r,
            "total": count, "nan": nans}  # fmt: skip


def _time(solver: Callable[[Any, float], object], T: list, q7: list, rounds: int) -> np.ndarray:
    clock = time.perf_counter_ns
    out = []
    for _ in range(rounds):
        for pose, x in zip(T, q7):
            t0 = clock()
            solver(pose, x)
            out.append(clock() - t0)
    return np.asarray(out) / 1e3


def _batch_rows(robot: rr.Robot, name: str, q: np.ndarray, T: np.ndarray, count: int,
                results: dict) -> None:  # fmt: skip
    """The batch form's rows (all threads, one thread) into ``results``."""
    for threads in (None, 1):
        previous = _compile.threads(threads)
        try:
            at_q7_batch(robot, T, q[:, 6])
            reps = []
            for _ in range(5):
                t0 = time.perf_counter()
                batch = at_q7_batch(robot, T, q[:, 6])
                reps.append((time.perf_counter() - t0) / count * 1e6)
        finally:
            _compile.threads(previous)
        label = f"redres at_q7_batch ({'all' if threads is None else 1} threads)"
        rows = np.arange(8)[None, :] < batch.count[:, None]
        near = np.abs((batch.q - q[:, None] + np.pi) % (2 * np.pi) - np.pi).max(axis=2)
        found = float((np.where(rows, near, np.inf).min(axis=1) < 1e-6).mean())
        qual = {
            "solutions": float(batch.count.mean()), "found": found, "nan": 0,
            "p": float(batch.position_error.max()), "r": float(batch.rotation_error.max()),
            "total": int(batch.count.sum()),
        }  # fmt: skip
        median = float(np.median(reps))
        results[(name, label)] = (median, median / qual["solutions"], qual)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=1000)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    results: dict[tuple[str, str], tuple[float, float, dict]] = {}
    missing: dict[str, str] = {}
    poses: dict[str, tuple[rr.Robot, np.ndarray, np.ndarray]] = {}
    for name in ("panda", "iiwa14"):
        robot = rr.models.load(name)
        rng = np.random.default_rng(0)
        q = rng.uniform(robot.q_min, robot.q_max, size=(args.poses, 7))
        T = np.array([robot.fk(x) for x in q])
        q7 = [float(x) for x in q[:, 6]]
        contenders: dict[str, Solver] = {
            "redres at_q7": (lambda T: T, lambda pose, x, robot=robot: at_q7(robot, pose, q7=x).q)
        }
        params = {k: q7 for k in ("redres at_q7", "geofikpy", "frankik")}
        if name == "iiwa14":  # the arm angle of each configuration: its own parameter
            label = "redres at_arm_angle (arm angle)"
            params[label] = [float(x) for x in rr.tasks.ArmAngleTask().values(robot, q)]
            contenders[label] = (
                lambda T: T,
                lambda pose, x, robot=robot: at_arm_angle(robot, pose, arm_angle=x).q,
            )
        if name == "panda":
            _check_frames(robot, rng)
            solvers, missing = _peers(robot)
            contenders.update(solvers)
        inputs = {k: [prepare(pose) for pose in T] for k, (prepare, _) in contenders.items()}
        sols = {
            k: [f(i, x) for i, x in zip(inputs[k], params[k])] for k, (_, f) in contenders.items()
        }
        times: dict[str, list[np.ndarray]] = {k: [] for k in contenders}
        for _ in range(args.rounds):  # interleaved: machine noise hits all alike
            for k, (_, f) in contenders.items():
                times[k].append(_time(f, inputs[k], params[k], 1))
        for k in contenders:
            t = np.concatenate(times[k])
            qual = _quality(robot, q, T, sols[k])
            median = float(np.median(t))
            results[(name, k)] = (median, median / max(qual["solutions"], 1e-300), qual)
        poses[name] = (robot, q, T)
    # the batches after every per-call timing: their threads (OpenMP, spinning for a
    # while after a parallel region) would compete with the single calls
    for name, (robot, q, T) in poses.items():
        _batch_rows(robot, name, q, T, args.poses, results)
    load = os.getloadavg()
    print(f"# analytic IK at given q7 (iiwa14 also at its arm angle), {args.poses} random "
          f"in-limit poses (seed 0), Panda to its hand TCP, iiwa14 to its flange")  # fmt: skip
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, numba threads "
          f"{_compile.threads(None)}")  # fmt: skip
    print(f"{'arm':7} {'solver':34} {'µs/call':>8} {'µs/sol':>7} {'sols':>5} {'orig %':>7} "
          f"{'worst m':>9} {'worst rad':>9} {'NaN sols':>8}")  # fmt: skip
    for (arm, k), (median, per_sol, qual) in sorted(
        results.items(), key=lambda r: r[0][0] != "panda"
    ):
        per = f"{per_sol:7.2f}"
        print(f"{arm:7} {k:34} {median:8.2f} {per:>7} {qual['solutions']:5.2f} "
              f"{100 * qual['found']:7.1f} {qual['p']:9.1e} {qual['r']:9.1e} "
              f"{qual['nan']:8d}")  # fmt: skip
    for k, why in missing.items():
        print(f"# {k}: {why}")
    print("# batch rows: µs per pose (median of 5 calls over all poses), FK errors the kernel's;")
    print("# at_arm_angle: the iiwa14 (S-R-S) at the arm angle instead of q7, compiled closed form")
    print("# sols: finite solutions per pose; NaN sols: solutions holding NaN (left out)")


if __name__ == "__main__":
    main()
