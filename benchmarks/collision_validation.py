"""Never penetrates (issue 39): collision avoidance as a hard constraint, measured.

1. Random scenes (:func:`redres.testing.collision_scene`: obstacles placed on the arm's
   way, a tip path that drives into them, sometimes a table the path goes below) on the
   built-in Panda and iiwa14 and on the Menagerie iiwa14 (a file arm, capsules fitted to
   its collision geometry), closed loop at 1 kHz: the QP scheme with
   ``Collisions(influence=0.10, safety=0.01, self_collision=True)``, then, on the same
   scenes, gradient projection with the soft obstacle objective (self pairs too) alone.
   Every pair (environment and self) is measured at every step; reported: the smallest
   distance over every pair and step, and how many scenes and steps go below ``d_s`` and
   below 0 (contact).
2. Self-collision paths: the Panda's hand driven into its base and upper arm, the iiwa14's
   forearm folded onto its upper arm: the smallest self distance with and without the
   constraint, and the task error where the constraint binds.

Run: ``python benchmarks/collision_validation.py [--scenes 200] [--steps 500]`` (about
ten minutes for the defaults on a loaded 2-core machine).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))

from _common import machine

import redres as rr
from redres.collision import Collisions
from redres.control.trajectories import Line
from redres.objectives import ObstacleObjective
from redres.resolution import GradientProjectionScheme, QPScheme
from redres.tasks import FrameTask
from redres.testing import collision_scene

DT = 1e-3
INFLUENCE, SAFETY = 0.10, 0.01
POSITION = ["x", "y", "z"]


def robots() -> dict[str, tuple[rr.Robot, list[tuple[str, str]]]]:
    """The arms and their allowed pairs: the Menagerie iiwa14's fitted capsules of links
    two joints apart overlap in most configurations (link5 and link7 as soon as joint 6
    bends), so those pairs are allowed, as an SRDF would disable them."""
    # the Menagerie file has no velocity limits: KUKA's published ones (the built-in's)
    file_arm = rr.models.menagerie("iiwa14").with_limits(qd_max=rr.models.iiwa14().qd_max)
    names = [c.name for c in file_arm.capsules]
    allowed = list(zip(names, names[2:]))
    return {
        "panda": (rr.models.panda(), []),
        "iiwa14": (rr.models.iiwa14(), []),
        "menagerie iiwa14 (fitted)": (file_arm, allowed),
    }


def _clearances(model: object, qs: np.ndarray) -> np.ndarray:
    """The smallest distance over every pair at each configuration, m."""
    return np.array([model.distances(q).min() for q in qs])  # type: ignore[attr-defined]


def run_scene(
    robot: rr.Robot, scene: object, steps: int, soft: bool, allowed: list[tuple[str, str]]
) -> tuple[np.ndarray, float]:
    """One closed-loop run; returns the per-step smallest distance and the largest
    position error (m)."""
    q0, end, obstacles = scene.q0, scene.end, scene.obstacles  # type: ignore[attr-defined]
    collisions = Collisions(obstacles, influence=INFLUENCE, safety=SAFETY, self_collision=True,
                            allowed=allowed)  # fmt: skip
    if soft:
        objective = ObstacleObjective(obstacles, influence=INFLUENCE, self_collision=True)
        objective.collision_model(robot)  # the same pairs as the constraint's:
        objective._model = collisions.model(robot)
        scheme: object = GradientProjectionScheme([objective], k_null=1.0)
    else:
        scheme = QPScheme(DT, collisions=collisions)
    trajectory = Line(robot.fk(q0), end, steps * DT)
    log = rr.run(robot, FrameTask(rows=POSITION), trajectory, scheme, dt=DT, q0=q0,
                 progress=False)  # type: ignore[arg-type]  # fmt: skip
    d = _clearances(collisions.model(robot), log.q)
    return d, float(log.position_error.max())


def random_scenes(scenes: int, steps: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    arms = robots()
    names = list(arms)
    print(f"## {scenes} random scenes, {steps} steps each at {1 / DT:.0f} Hz, seed {seed}")
    totals = {"qp": [], "soft": []}  # type: dict[str, list[tuple[str, np.ndarray, float]]]
    t0 = time.perf_counter()
    for k in range(scenes):
        name = names[k % len(names)]
        robot, allowed = arms[name]
        scene = collision_scene(robot, rng, allowed=allowed)
        for kind in ("qp", "soft"):
            d, err = run_scene(robot, scene, steps, kind == "soft", allowed)
            totals[kind].append((name, d, err))
        if (k + 1) % 20 == 0:
            qp_min = min(r[1].min() for r in totals["qp"])
            print(f"  {k + 1} scenes, {time.perf_counter() - t0:.0f} s, QP smallest "
                  f"{qp_min:+.7f} m", flush=True)  # fmt: skip
    elapsed = time.perf_counter() - t0
    print(f"({elapsed:.0f} s, load {os.getloadavg()[0]:.2f})\n")
    print("| scheme | arm | scenes | steps | smallest distance, m | scenes < d_s | steps < d_s "
          "| scenes < 0 | steps < 0 |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for kind, label in (("qp", "QP + collisions"), ("soft", "gradient projection, soft")):
        for arm in [*names, "all"]:
            rows = [r for r in totals[kind] if arm in ("all", r[0])]
            d = np.concatenate([r[1] for r in rows])
            below = sum(int(r[1].min() < SAFETY - 1e-6) for r in rows)
            contact = sum(int(r[1].min() < 0.0) for r in rows)
            steps_below = int((d < SAFETY - 1e-6).sum())
            print(f"| {label} | {arm} | {len(rows)} | {d.size} | {d.min():+.7f} | {below} | "
                  f"{steps_below} | {contact} | {int((d < 0).sum())} |")  # fmt: skip
    worst = min(totals["qp"], key=lambda r: r[1].min())
    print(f"\nQP: smallest distance {worst[1].min():+.9f} m (d_s = {SAFETY} m; goal >= "
          f"{SAFETY - 1e-6:.6f}) on {worst[0]}")  # fmt: skip


def self_paths() -> None:
    print("\n## Self-collision paths (position task, 2 s at 1 kHz)\n")
    # the iiwa14's built-in capsules meet at the elbow (that pair is left out) and its
    # joint-4 limit (120°) keeps the hand 0.0999 m off the upper arm: d_s = 0.12 m there
    panda, iiwa = rr.models.panda(), rr.models.iiwa14()
    cases = {
        "panda: hand into base and upper arm": (
            panda,
            panda.neutral(),
            [0.12, 0.05, 0.25],
            INFLUENCE,
            SAFETY,
        ),
        "iiwa14: forearm folded onto upper arm": (
            iiwa,
            np.array([0, 0.6, 0, -1.6, 0, 0.6, 0]),
            [0.25, 0.0, 0.5],
            0.20,
            0.12,
        ),
    }
    print("| path | scheme | smallest self distance, m | steps binding | max task error, m "
          "| task error where binding (median, max), m |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    for label, (robot, q0, goal, influence, safety) in cases.items():
        collisions = Collisions([], influence=influence, safety=safety, self_collision=True)
        model = collisions.model(robot)
        for kind in ("qp", "qp + collisions"):
            scheme = QPScheme(DT, collisions=collisions if kind != "qp" else None)
            bound: list[bool] = []
            steps = int(2.0 / DT)
            trajectory = Line(robot.fk(q0), goal, 1.5)
            task = FrameTask(rows=POSITION)
            controller = rr.Controller(robot, task, scheme, dt=DT, gain=50.0)
            q, errors, distances = q0.copy(), [], []
            for i in range(steps):
                sample = trajectory.sample(min(i * DT, 1.5))
                task.set_target(sample.pose, sample.twist, validate=False)
                q = controller.step(q)
                errors.append(float(np.linalg.norm(robot.fk(q)[:3, 3] - sample.pose[:3, 3])))
                distances.append(float(model.distances(q).min()))
                result = controller.result
                details = result.details if result is not None else None
                contact = getattr(details, "collisions", None)
                bound.append(bool(contact is not None and contact.bound))
            e, b = np.array(errors), np.array(bound)
            where = f"{np.median(e[b]):.4f}, {e[b].max():.4f}" if b.any() else "-"
            print(f"| {label} (d_s = {safety}) | {kind} | {min(distances):+.6f} | {int(b.sum())} | "
                  f"{e.max():.4f} | {where} |")  # fmt: skip


def scene_parser(doc: str, scenes: int, steps: int) -> argparse.ArgumentParser:
    """The command line of a benchmark over random scenes: ``--scenes``, ``--steps``,
    ``--seed`` (the collision benchmarks share it)."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=scenes)
    parser.add_argument("--steps", type=int, default=steps)
    parser.add_argument("--seed", type=int, default=39)
    return parser


def main() -> None:
    parser = scene_parser(__doc__, 200, 500)
    parser.add_argument("--skip-scenes", action="store_true")
    args = parser.parse_args()
    print(f"# Collision validation — {machine()}\n")
    if not args.skip_scenes:
        random_scenes(args.scenes, args.steps, args.seed)
    self_paths()


if __name__ == "__main__":
    main()
