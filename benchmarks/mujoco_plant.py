"""The same circle on MuJoCo's Panda: redres' controller next to mink, in one run.

The MuJoCo Menagerie Panda (the copy redres ships, meshes removed) follows a 5 cm
circle (4 s a turn, 0.5 s ramp, 4.5 s) through its position actuators at 1 kHz, the plant
of ``redres.sim`` (MuJoCo integrates; gravity compensated, the command's velocity fed
forward, as a robot's joint controller does). Each controller computes the next joint
command from its own last command:

* redres ``Controller`` (gradient projection of the joint-limit cost, its fused path),
  through ``redres.sim.run_on_mujoco``;
* mink ``solve_ik`` (a frame task and a 1e-3 posture task, configuration limits, DAQP),
  integrated with ``Configuration.integrate_inplace`` as mink's examples do, on the same
  plant; and mink's own habit, ``data.ctrl = configuration.q`` on the bare Menagerie
  servos (no gravity compensation, no feedforward), for reference.

Reported: median µs per control step of the controller alone (p99), and the tracking error
of the site measured by MuJoCo (max after the 0.5 s ramp, RMS), with the load average.

Run: ``python benchmarks/mujoco_plant.py``.
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import load_text, machine, table

import redres as rr
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme
from redres.sim import MujocoPlant, run_on_mujoco

DT = 1e-3
DURATION = 4.5


def _plant() -> MujocoPlant:
    return MujocoPlant(rr.models.menagerie_path("panda"), timestep=DT)


def _errors(plant: MujocoPlant, qs: np.ndarray, targets: np.ndarray) -> tuple[float, float]:
    e = np.array([np.linalg.norm(plant.pose(q)[:3, 3] - t) for q, t in zip(qs, targets)])
    late = e[int(0.5 / DT) :]
    return float(late.max()), float(np.sqrt(np.mean(late**2)))


def redres_run() -> tuple[np.ndarray, tuple[float, float]]:
    plant = _plant()
    robot = plant.robot()
    q0 = robot.neutral()
    circle = rr.control.Circle(robot.fk(q0), 0.05, 4.0, ramp=0.5, normal=(1.0, 0.0, 0.0))
    scheme = GradientProjectionScheme([JointLimitObjective()])
    run_on_mujoco(plant, rr.tasks.FrameTask(), circle, scheme, q0=q0, duration=0.1)  # compile
    log = run_on_mujoco(plant, rr.tasks.FrameTask(), circle, scheme, q0=q0, duration=DURATION)
    return log.step_time_ns / 1e3, _errors(plant, log.q, log.target)


def mink_run(habit: bool) -> tuple[np.ndarray, tuple[float, float]] | None:
    try:
        import mink
        import mujoco
    except ImportError:
        return None
    plant = _plant()
    robot = plant.robot()
    model, data = plant.model, plant.data
    q0 = robot.neutral()
    circle = rr.control.Circle(robot.fk(q0), 0.05, 4.0, ramp=0.5, normal=(1.0, 0.0, 0.0))
    configuration = mink.Configuration(model)
    configuration.update(q0.copy())
    frame = mink.FrameTask(plant.frame, "site", position_cost=1.0, orientation_cost=1.0)
    posture = mink.PostureTask(model, cost=1e-3)
    posture.set_target(q0)
    limits = [mink.ConfigurationLimit(model)]
    plant.reset(q0)
    steps = round(DURATION / DT)
    times, qs, targets = np.empty(steps), np.empty((steps, 7)), np.empty((steps, 3))
    for k in range(steps):
        t0 = time.perf_counter_ns()  # as run_on_mujoco's: the reference sample included
        T = circle.sample(k * DT).pose
        frame.set_target(mink.SE3.from_matrix(T))
        v = mink.solve_ik(configuration, [frame, posture], DT, "daqp", damping=1e-6, limits=limits)
        configuration.integrate_inplace(v, DT)
        times[k] = (time.perf_counter_ns() - t0) / 1e3
        qs[k], targets[k] = plant.q, T[:3, 3]
        if habit:  # mink's examples: the configuration straight into the servos
            data.ctrl[:] = configuration.q
            mujoco.mj_step(model, data)
        else:
            plant.follow(configuration.q.copy(), v, 1)
    return times, _errors(plant, qs, targets)


def main() -> int:
    before = os.getloadavg()
    runs = {"redres Controller (gradient projection, fused)": redres_run()}
    for habit, name in ((False, "mink solve_ik (frame + posture, DAQP)"),
                        (True, "mink solve_ik, ctrl = q on the bare servos")):  # fmt: skip
        found = mink_run(habit)
        if found is not None:
            runs[name] = found
    after = os.getloadavg()
    base = float(np.median(runs["redres Controller (gradient projection, fused)"][0]))
    rows = []
    for name, (times, (worst, rms)) in runs.items():
        t = float(np.median(times))
        rows.append([name, f"{t:.1f}", f"{np.percentile(times, 99):.1f}", f"{t / base:.1f}x",
                     f"{1e3 * worst:.3f}", f"{1e3 * rms:.3f}"])  # fmt: skip
    print("## The same circle on MuJoCo's Panda: redres and mink\n")
    print(f"{machine()}; {load_text(before, after)}\n")
    head = ["controller", "median µs / step", "p99 µs", "time / redres",
            "max error mm (after 0.5 s)", "RMS error mm"]  # fmt: skip
    print(table(head, rows))
    if len(runs) == 1:
        print("\nmink is not installed (`pip install mink`): skipped.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
