"""Collision avoidance (issue 39): the time of one step, medians with the load average.

1. ``QPScheme.step`` on the Panda (built-in capsules): without collisions (today's QP
   step), with ``Collisions`` and no pair within ``d_i`` (0 active), and with obstacles
   placed so that about 20 pairs are active; each on a task velocity whose answer the
   rows do not change (``inside``) and on one that drives into the obstacles (binding).
2. Gradient projection with the soft :class:`~redres.objectives.ObstacleObjective` on
   the Menagerie iiwa14 (capsules fitted to its collision geometry), three obstacles
   near the arm; runs against any redres tree (``PYTHONPATH=...``) for before/after.
3. :meth:`CollisionModel.compute` alone (one Pinocchio pass and the kernel).

Run: ``python benchmarks/collision_step.py`` (about a minute).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from _common import machine

import redres as rr
from redres.objectives import ObstacleObjective, SphereObstacle
from redres.resolution import GradientProjectionScheme

DT = 1e-3


def per_call(contenders: dict, rounds: int = 7, calls: int = 300) -> dict[str, float]:
    """Median time of one call (µs), every call timed alone, the contenders in turn for
    ``rounds`` rounds (a median of single calls is robust to a loaded machine)."""
    samples: dict[str, list[float]] = {name: [] for name in contenders}
    for fn in contenders.values():
        fn()
    for _ in range(rounds):
        for name, fn in contenders.items():
            for _ in range(calls):
                t0 = time.perf_counter_ns()
                fn()
                samples[name].append((time.perf_counter_ns() - t0) / 1e3)
    return {name: float(np.median(v)) for name, v in samples.items()}


def _ring(robot: rr.Robot, q: np.ndarray, per_capsule: int, gap: float) -> list[SphereObstacle]:
    """Small balls ``gap`` m off each link capsule's surface, around its middle."""
    out = []
    rng = np.random.default_rng(1)
    for cap in robot.capsules:
        T = robot.fk(q, cap.frame)
        a, b = T[:3, :3] @ cap.a + T[:3, 3], T[:3, :3] @ cap.b + T[:3, 3]
        length = float(np.linalg.norm(b - a))
        axis = (b - a) / length if length > 1e-9 else np.array([0.0, 0.0, 1.0])
        for _ in range(per_capsule):
            side = np.cross(axis, rng.normal(size=3))
            side /= np.linalg.norm(side)
            centre = 0.5 * (a + b) + (cap.radius + gap + 0.02) * side
            out.append(SphereObstacle(centre, 0.02, f"ball{len(out)}"))
    return out


def qp_steps() -> None:
    from redres.collision import Collisions
    from redres.resolution import QPScheme

    robot = rr.models.panda()
    q = np.array([0.0, -0.3, 0.0, -2.0, 0.0, 1.8, 0.8])
    J = robot.jacobian(q)
    near = _ring(robot, q, 3, 0.06)
    far = [SphereObstacle([2.0, 2.0, 2.0], 0.05, "far")]
    schemes = {
        "QP (today)": QPScheme(DT),
        "QP + collisions, 0 active": QPScheme(DT, collisions=Collisions(far,
                                                                         self_collision=False)),
        "QP + collisions, ~20 active": QPScheme(DT, collisions=Collisions(near,
                                                                           self_collision=False)),
    }  # fmt: skip
    probe = schemes["QP + collisions, ~20 active"].step(robot, q, J, np.zeros(6))
    count = len(probe.details.collisions.active)  # type: ignore[union-attr]
    schemes["QP + collisions, ~20 active"].reset()
    print(f"Panda, {len(near)} balls near its {len(robot.capsules)} capsules: {count} pairs "
          f"within d_i = 0.10 m\n")  # fmt: skip
    for label, xd in (("inside", 0.05 * np.array([0, 0, 0, 0, 0, 0.2])),
                      ("driving", np.array([0.0, 0.5, -0.5, 0.0, 0.0, 0.0]))):  # fmt: skip
        calls = {}
        for name, scheme in schemes.items():
            scheme.qd_prev = np.zeros(7)

            def step(scheme: object = scheme, xd: np.ndarray = xd) -> object:
                scheme.qd_prev = np.zeros(7)  # type: ignore[attr-defined]
                return scheme.step(robot, q, J, xd)  # type: ignore[attr-defined]

            calls[name] = step
        times = per_call(calls)
        result = schemes["QP + collisions, ~20 active"].step(robot, q, J, xd)
        binding = len(result.details.collisions.binding)
        print(f"task velocity {label} ({binding} rows binding with ~20 active):")
        for name, t in times.items():
            print(f"  {name:<30} {t:8.1f} µs")
    print()


def soft_step() -> None:
    robot = rr.models.menagerie("iiwa14")
    q = np.array([0.0, 0.5, 0.0, -1.2, 0.0, 0.8, 0.0])
    J = robot.jacobian(q)
    obstacles = _ring(robot, q, 1, 0.03)[:3]
    objective = ObstacleObjective(obstacles, influence=0.15)
    scheme = GradientProjectionScheme([objective], k_null=1.0)
    xd = np.array([0.05, 0.0, 0.0, 0.0, 0.0, 0.0])
    times = per_call({"soft": lambda: scheme.step(robot, q, J, xd)})
    print(
        f"gradient projection + ObstacleObjective, Menagerie iiwa14 ({len(robot.capsules)} "
        f"fitted capsules, {len(obstacles)} obstacles): {times['soft']:.1f} µs"
    )


def distances_only() -> None:
    from redres.collision import CollisionModel

    for name in ("panda", "iiwa14"):
        robot = getattr(rr.models, name)()
        q = robot.neutral()
        model = CollisionModel(robot, _ring(robot, q, 4, 0.05))
        times = per_call({"compute": lambda m=model, q=q: m.compute(q)})
        print(
            f"CollisionModel.compute, {name}: {len(model.pairs)} pairs "
            f"({sum(p.self_pair for p in model.pairs)} self): {times['compute']:.1f} µs"
        )


def main() -> None:
    print(f"# Collision step times — {machine()}")
    print(f"load average before: {os.getloadavg()}\n")
    if hasattr(rr, "Collisions"):
        qp_steps()
        distances_only()
    soft_step()
    print(f"\nload average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
