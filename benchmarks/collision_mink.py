"""Collision avoidance side by side with mink (issue 39): same arm, scene, pairs and damper.

redres' ``QPScheme(collisions=Collisions(...))`` next to mink's ``solve_ik`` with
``ConfigurationLimit``, ``VelocityLimit`` and ``CollisionAvoidanceLimit`` (DAQP), in one
run. The MuJoCo model mink reads is the URDF Panda of ``benchmarks/peers.py`` whose only
geoms are redres' link capsules of the built-in Panda (``<geom type="capsule" fromto=...>``
on the bodies their joints move, checked against redres' at random configurations) and
the obstacles as MuJoCo sphere, box, capsule and plane geoms; mink is given exactly the
pairs redres checks (one geom pair each).

The damper (Faverjon & Tournassoud 1987) in both. redres bounds the distance's rate,
``ḋ ≥ −ξ (d − d_s)/(d_i − d_s)``. mink's QP variable is the step ``Δq = v dt`` and its row
(``limits/collision_avoidance_limit.py``) reads ``Δd ≥ −gain (d − d_min)/dt`` for
``d > d_min`` and ``Δd ≥ 0`` below, for pairs closer than
``collision_detection_distance``. So ``d_min = d_s``, ``collision_detection_distance =
d_i`` and ``gain = ξ dt²/(d_i − d_s)`` give the same row above ``d_s``; below ``d_s``
mink only forbids approach where redres demands separation.

1. One control step at one configuration with about 20 pairs within ``d_i`` (balls around
   the links, self pairs too): redres ``Controller.step`` (kinematics, task, QP with
   the rows) against mink's ``Configuration.update`` + ``solve_ik`` + integration, both
   with and without collisions; medians of single timed calls, interleaved.
2. Closed loops on the same random scenes (``redres.testing.collision_scene``: obstacles on
   the arm's way, a tip path driving into them, sometimes a table): the tip follows the
   path at 1 kHz under each library; every pair's distance at every step is measured by
   redres' ``CollisionModel`` (checked against MuJoCo's ``mj_geomDistance`` at each run's
   closest step): the smallest distance reached, the scenes below ``d_s`` and below 0, the
   median step time.

Not the same in the two: redres' task is exact (CLIK, gain 50/s, reference velocity fed
forward), mink's a least-squares cost solved for the whole error in one step (gain 1, no
feed-forward); redres also bounds joint accelerations (mink does not); when the rows and
the limits conflict redres lets the acceleration limits yield first and keeps the rows,
mink's QP fails (``NoSolutionFound``: the arm is held still for that step, counted).

Run: ``python benchmarks/collision_mink.py [--scenes 50] [--steps 500]`` (about a minute).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from _common import load_text, machine, table
from collision_step import _ring, per_call
from collision_validation import scene_parser
from peers import capsule_gap, import_mink, mujoco_capsule_arm

import redres as rr
from redres.collision import Collisions
from redres.control.trajectories import Line
from redres.resolution import QPScheme
from redres.tasks import FrameTask
from redres.testing import collision_scene

DT = 1e-3
INFLUENCE, SAFETY, GAIN = 0.10, 0.01, 0.5
POSITION = ["x", "y", "z"]
TIP_BODY = "panda_hand_tcp"
TITLE = "Collision avoidance as a hard constraint: redres and mink"
DEFAULT_GAIN = "mink, its default gain 0.85"


NOT_THE_SAME = """
Where the two are not the same: redres' task is exact (CLIK, gain 50/s, the reference
velocity fed forward), mink's a least-squares cost solved for the whole error in one step;
redres also bounds joint accelerations and mink does not (the path is faster than the arm
may accelerate: most of the final tip error is that, more of it for redres); below d_s
mink only forbids approach (Δd ≥ 0) where redres demands separation (the first two runs
never went there); a step is each library's whole control step, its own kinematics included (mink's
`Configuration.update`: MuJoCo's; redres': the compiled chain and Pinocchio). The last
row keeps mink's default gain 0.85 with the same distances: its bound
``Δd ≥ −gain (d − d_min)/dt`` is then 850 times the gap per 1 ms step, no braking
before ``d_min``."""


def mink_gain() -> float:
    """mink's ``gain`` that gives redres' damper row above ``d_s`` (module docstring)."""
    return GAIN * DT * DT / (INFLUENCE - SAFETY)


class RedresLoop:
    """redres' control step: ``Controller`` with a position task and the QP scheme."""

    def __init__(self, robot: rr.Robot, obstacles: list[Any], collide: bool = True) -> None:
        self.collisions = Collisions(obstacles, influence=INFLUENCE, safety=SAFETY, gain=GAIN)
        scheme = QPScheme(DT, collisions=self.collisions if collide else None)
        self.task = FrameTask(rows=POSITION)
        self.controller = rr.Controller(robot, self.task, scheme, dt=DT, gain=50.0)
        self.failures = 0

    def step(self, q: np.ndarray, pose: np.ndarray, twist: np.ndarray) -> np.ndarray:
        self.task.set_target(pose, twist, validate=False)
        return self.controller.step(q)

    def active(self) -> int:
        result = self.controller.result
        return len(result.details.collisions.active) if result is not None else 0


class MinkLoop:
    """mink's control step on the same arm: a position task, the three limits, DAQP."""

    def __init__(self, mink: Any, mujoco: Any, robot: rr.Robot, obstacles: list[Any],
                 pairs: list[Any], collide: bool = True,
                 gain: float | None = None) -> None:  # fmt: skip
        self.mink, self.mujoco = mink, mujoco
        self.model = mujoco_capsule_arm(mujoco, robot, obstacles)
        self.configuration = mink.Configuration(self.model)
        self.task = mink.FrameTask(TIP_BODY, "body", position_cost=1.0, orientation_cost=0.0)
        names = [self.model.joint(j).name for j in range(robot.n)]
        self.limits = [mink.ConfigurationLimit(self.model),
                       mink.VelocityLimit(self.model, dict(zip(names, robot.qd_max)))]  # fmt: skip
        self.collision = mink.CollisionAvoidanceLimit(
            self.model, [([p.first], [p.second]) for p in pairs],
            gain=mink_gain() if gain is None else gain,
            minimum_distance_from_collisions=SAFETY, collision_detection_distance=INFLUENCE,
        )  # fmt: skip
        if collide:
            self.limits.append(self.collision)
        self.failures = 0

    def step(self, q: np.ndarray, pose: np.ndarray, twist: np.ndarray) -> np.ndarray:
        del twist  # mink's frame task has no feed-forward
        mink = self.mink
        self.configuration.update(q)
        self.task.set_target(mink.SE3.from_matrix(pose))
        try:
            v = mink.solve_ik(self.configuration, [self.task], DT, "daqp", limits=self.limits)
        except mink.NoSolutionFound:
            self.failures += 1
            return q.copy()
        return q + v * DT

    def active(self) -> int:
        return int(np.isfinite(self.collision.compute_qp_inequalities(self.configuration,
                                                                       DT).h).sum())  # fmt: skip

    def distance(self, q: np.ndarray, pairs: list[Any]) -> float:
        """The smallest distance over ``pairs`` at ``q`` by MuJoCo's ``mj_geomDistance``."""
        mujoco, model = self.mujoco, self.model
        data = mujoco.MjData(model)
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        fromto = np.empty(6)
        geom = mujoco.mjtObj.mjOBJ_GEOM
        ids = [(mujoco.mj_name2id(model, geom, p.first), mujoco.mj_name2id(model, geom, p.second))
               for p in pairs]  # fmt: skip
        return min(mujoco.mj_geomDistance(model, data, a, b, 1.0, fromto) for a, b in ids)


def one_step(mink: Any, mujoco: Any) -> None:
    robot = rr.models.panda()
    q = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8])
    balls: list[Any] = _ring(robot, q, 3, 0.06)
    loops = {"redres": RedresLoop(robot, balls)}
    pairs = loops["redres"].collisions.model(robot).pairs
    loops["mink"] = MinkLoop(mink, mujoco, robot, balls, pairs)  # type: ignore[assignment]
    gap = capsule_gap(mujoco, loops["mink"].model, robot)  # type: ignore[attr-defined]
    counted = len(loops["mink"].collision.geom_id_pairs)  # type: ignore[attr-defined]
    loops["redres, no collisions"] = RedresLoop(robot, balls, collide=False)
    loops["mink, no collisions"] = MinkLoop(mink, mujoco, robot, balls, pairs, collide=False)  # type: ignore[assignment]
    pose = robot.fk(q)
    pose[:3, 3] += [0.0, 0.0005, -0.0005]  # 0.7 mm off: the task drives towards the balls
    twist = np.array([0.0, 0.5, -0.5, 0.0, 0.0, 0.0])
    for loop in loops.values():
        loop.step(q, pose, twist)
    active = {name: loops[name].active() for name in ("redres", "mink")}
    print(f"Panda, {len(balls)} balls of 2 cm, 6 cm off its {len(robot.capsules)} capsules "
          f"({len(pairs)} pairs checked by redres, {counted} by mink; capsule ends agree to "
          f"{gap:.1e} m); pairs within d_i = {INFLUENCE} m: redres {active['redres']}, "
          f"mink {active['mink']}\n")  # fmt: skip
    before = os.getloadavg()
    times = per_call({name: (lambda lp=loop: lp.step(q, pose, twist))
                      for name, loop in loops.items()})  # fmt: skip
    after = os.getloadavg()
    rows = [[name, f"{t:.1f}", f"{t / times['redres']:.1f}x"] for name, t in times.items()]
    print(table(["control step", "median µs", "time / redres with collisions"], rows))
    print(f"\nredres is {times['mink'] / times['redres']:.1f}x faster with collisions "
          f"(goal ≥ 5x); {load_text(before, after)}\n")  # fmt: skip


def _run(loop: Any, q0: np.ndarray, trajectory: Line, steps: int) -> tuple[np.ndarray, np.ndarray]:
    qs, times = np.empty((steps + 1, len(q0))), np.empty(steps)
    qs[0] = q = q0.copy()
    for i in range(steps):
        sample = trajectory.sample(min((i + 1) * DT, trajectory.duration))
        t0 = time.perf_counter_ns()
        q = loop.step(q, sample.pose, sample.twist)
        times[i] = (time.perf_counter_ns() - t0) / 1e3
        qs[i + 1] = q
    return qs, times


def closed_loops(mink: Any, mujoco: Any, scenes: int, steps: int, seed: int) -> None:
    robot = rr.models.panda()
    rng = np.random.default_rng(seed)
    names = ("redres", "mink", DEFAULT_GAIN)
    found: dict[str, list[tuple[float, float]]] = {name: [] for name in names}
    step_times: dict[str, list[np.ndarray]] = {name: [] for name in names}
    failures = dict.fromkeys(names, 0)
    check = 0.0
    before = os.getloadavg()
    for _ in range(scenes):
        scene = collision_scene(robot, rng)
        redres_loop = RedresLoop(robot, scene.obstacles)
        model = redres_loop.collisions.model(robot)
        mink_loop = MinkLoop(mink, mujoco, robot, scene.obstacles, model.pairs)
        mink_default = MinkLoop(mink, mujoco, robot, scene.obstacles, model.pairs, gain=0.85)
        trajectory = Line(robot.fk(scene.q0), scene.end, steps * DT)
        loops = {"redres": redres_loop, "mink": mink_loop, DEFAULT_GAIN: mink_default}
        for name, loop in loops.items():
            qs, times = _run(loop, scene.q0, trajectory, steps)
            d = np.array([model.distances(q).min() for q in qs])
            worst = int(np.argmin(d))
            check = max(check, abs(mink_loop.distance(qs[worst], model.pairs) - d[worst]))
            end = float(np.linalg.norm(robot.fk(qs[-1])[:3, 3] - scene.end))
            found[name].append((float(d.min()), end))
            step_times[name].append(times)
            failures[name] += loop.failures
    after = os.getloadavg()
    print(f"{scenes} random scenes (seed {seed}), {steps} steps each at {1 / DT:.0f} Hz, "
          f"d_s = {SAFETY} m; {load_text(before, after)}\n")  # fmt: skip
    rows = []
    for name in names:
        d = np.array([r[0] for r in found[name]])
        end = np.array([r[1] for r in found[name]])
        t = np.concatenate(step_times[name])
        rows.append([name, f"{d.min():+.6f}", f"{int((d < SAFETY - 1e-6).sum())} / {scenes}",
                     f"{int((d < 0.0).sum())} / {scenes}", f"{np.median(t):.1f}",
                     f"{1e3 * np.median(end):.1f}", str(failures[name])])  # fmt: skip
    print(table(["library", "smallest distance, m", "scenes < d_s", "scenes < 0",
                 "median µs / step", "median final tip error, mm", "QP failures (held)"],
                rows))  # fmt: skip
    print(f"\nDistances by redres' CollisionModel; MuJoCo's mj_geomDistance at each run's "
          f"closest step agrees to {check:.1e} m.")  # fmt: skip


def main() -> None:
    args = scene_parser(__doc__, 50, 500).parse_args()
    found = import_mink()
    print(f"## {TITLE}\n\n{machine()}\n")
    if found is None:
        print("mink is not installed: skipped")
        return
    mink, mujoco = found
    print(f"Damper: d_i = {INFLUENCE} m, d_s = {SAFETY} m, ξ = {GAIN} m/s, dt = {DT} s; mink: "
          f"collision_detection_distance = {INFLUENCE}, minimum_distance_from_collisions = "
          f"{SAFETY}, gain = ξ dt²/(d_i − d_s) = {mink_gain():.4g}.\n")  # fmt: skip
    one_step(mink, mujoco)
    closed_loops(mink, mujoco, args.scenes, args.steps, args.seed)
    print(NOT_THE_SAME)


if __name__ == "__main__":
    main()
