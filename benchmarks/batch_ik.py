"""Batch position IK: pose targets solved per second, on one thread and on all cores.

For each arm (Panda to its TCP, iiwa 14 to its flange), ``--targets`` configurations are
drawn uniformly within the joint limits (seeded) and their tip poses are the targets, as
in ``ik_compare.py``. Contenders, same targets:

* ``rr.batch.ik`` on 1 thread and on all cores: one parallel compiled kernel, each target
  from the neutral configuration, then up to 50 seeded random restarts (no clock);
* pytorch_kinematics ``PseudoInverseIK`` on the CPU (``pip install pytorch-kinematics``;
  skipped with a note if it is not installed), float64, all cores (``torch`` threads),
  batched over targets × 10 random starts, 100 iterations, its LM damping and joint-limit
  enforcement, stopping tolerances set tight enough (1e-7 m, 1e-6 rad) that meeting them
  meets ours; its chain is checked to be the same arm first (tip poses equal to 1e-6: its
  URDF parser stores the joint origins in float32, 8e-8 m off; our check below sees it).

A success is checked here, never taken from the library's flag: Pinocchio forward
kinematics (``robot.fk``) of the returned configuration within 1e-6 m and 1e-5 rad and
every joint within its limits (``ik_compare.solved``). The table gives the median wall
time of ``--rounds`` runs as targets per second, targets per CPU-second of the process
(``time.process_time``, all threads), and the success rate.

Run from the repository root: ``python benchmarks/batch_ik.py [--quick] [--targets 10000]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))  # this checkout's redres

import peers
from _common import load_text, machine, median, table
from ik_compare import solved

import redres as rr

#: A run returns the configurations (N, n) of the targets, one per target.
Solver = Callable[[np.ndarray], np.ndarray]
TORCH_STARTS, TORCH_ITERATIONS = 10, 100


def redres_solver(robot: rr.Robot, frame: str, threads: int | None) -> Solver:
    return lambda T: rr.batch.ik(robot, T, frame, threads=threads).q


def import_pytorch_kinematics() -> Any:
    try:
        import pytorch_kinematics
        import torch
    except ImportError:
        peers.note("pytorch_kinematics (pip install pytorch-kinematics) is not installed: skipped")
        return None
    return pytorch_kinematics, torch


def torch_solver(name: str, robot: rr.Robot, frame: str) -> Solver | None:
    """pytorch_kinematics' batch IK on the CPU, after checking its chain is redres' arm."""
    modules = import_pytorch_kinematics()
    if modules is None:
        return None
    pk, torch = modules
    torch.set_num_threads(os.cpu_count() or 1)
    with peers.native_output_to_stderr():
        chain = pk.build_serial_chain_from_urdf(peers.arm_urdf(name).encode(), peers.TIP_LINK[name])
    chain = chain.to(dtype=torch.float64)
    rng = np.random.default_rng(0)
    for q in rng.uniform(robot.q_min, robot.q_max, (5, robot.n)):
        pose = chain.forward_kinematics(torch.tensor(q)).get_matrix()[0].numpy()
        gap = float(np.abs(pose - robot.fk(q, frame)).max())
        if not gap < 1e-6:  # its URDF parser rounds the joint origins to float32
            raise AssertionError(f"pytorch_kinematics' {name} differs from redres' by {gap:.3g}")
    limits = torch.tensor(np.stack([robot.q_min, robot.q_max], axis=1))
    starts = torch.tensor(rng.uniform(robot.q_min, robot.q_max, (TORCH_STARTS, robot.n)))
    starts[0] = torch.tensor(robot.neutral())
    solver = pk.PseudoInverseIK(
        chain, pos_tolerance=1e-7, rot_tolerance=1e-6, retry_configs=starts,
        joint_limits=limits, max_iterations=TORCH_ITERATIONS, early_stopping_any_converged=True,
    )  # fmt: skip

    def run(T: np.ndarray) -> np.ndarray:
        solution = solver.solve(pk.Transform3d(matrix=torch.tensor(T)))
        q = solution.solutions.numpy()  # (N, starts, n)
        first = np.argmax(solution.converged.numpy(), axis=1)  # first converged, else 0
        return q[np.arange(len(T)), first]

    return run


def measure(name: str, count: int, rounds: int) -> list[list[str]]:
    robot = rr.models.load(name)
    frame = peers.TIP_FRAME[name]
    rng = np.random.default_rng(7)
    targets = rr.batch.fk(robot, rng.uniform(robot.q_min, robot.q_max, (count, robot.n)), frame)
    solvers: dict[str, Solver | None] = {
        "rr.batch.ik, 1 thread": redres_solver(robot, frame, 1),
        f"rr.batch.ik, all cores ({os.cpu_count()})": redres_solver(robot, frame, None),
        f"pytorch_kinematics PseudoInverseIK, CPU, all cores ({TORCH_STARTS} starts)": (
            torch_solver(name, robot, frame)
        ),
    }
    rows = []
    for label, solve in solvers.items():
        if solve is None:
            continue
        solve(targets[:10])  # first call outside the timing (loads the kernels)
        walls, cpus, q = [], [], np.empty(0)
        for _ in range(rounds):
            wall, cpu = time.perf_counter(), time.process_time()
            q = solve(targets)
            walls.append(time.perf_counter() - wall)
            cpus.append(time.process_time() - cpu)
        ok = sum(solved(robot, frame, q[i], targets[i]) for i in range(count))
        wall, cpu = median(np.array(walls)), median(np.array(cpus))
        rows.append([name, label, f"{count / wall:,.0f}", f"{count / cpu:,.0f}",
                     f"{100 * ok / count:.2f} %"])  # fmt: skip
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="500 targets, 1 round")
    parser.add_argument("--targets", type=int, default=None, help="targets per arm")
    parser.add_argument("--rounds", type=int, default=None, help="runs per contender")
    args = parser.parse_args()
    count = args.targets or (500 if args.quick else 10_000)
    rounds = args.rounds or (1 if args.quick else 3)
    before = os.getloadavg()
    rows = [row for name in ("panda", "iiwa14") for row in measure(name, count, rounds)]
    after = os.getloadavg()
    print("## Batch position IK (pose targets per second)\n")
    print(f"{machine()}; {count:,} random reachable pose targets per arm (seed 7), medians of")
    print(
        f"{rounds} runs; success: Pinocchio FK within 1e-6 m and 1e-5 rad, limits enforced; "
        f"{load_text(before, after)}.\n"
    )
    headers = ["arm", "contender", "targets/s (wall)", "targets per CPU-s", "success"]
    print(table(headers, rows))


if __name__ == "__main__":
    main()
