"""Batches: Jacobian + damped rate step per item on the Panda, items per second.

Each item is one configuration: its tip Jacobian (6 x 7, world-aligned) and the damped
least-squares step ``qd = Jᵀ (J Jᵀ + λ² I)⁻¹ xd`` (λ = 0.01). Contenders, same items:

* ``rr.batch.rate_step`` on 1 thread and on all cores (one compiled parallel kernel),
  with its diagnostics, and on 1 thread with ``return_info=False`` (the singular values
  skipped, as the NumPy batch below does);
* NumPy vectorised: a Python loop of Pinocchio ``computeFrameJacobian`` into one
  ``(N, 6, 7)`` array, then one batched ``np.linalg.solve`` and ``matmul``;
* a Python loop of ``robot.jacobian(q)`` + ``rr.linalg.rate_step(J, xd, damping=λ)``;
* ``rr.batch.jacobian`` alone on 1 thread: the kinematics' share of the batch step.

Results are checked against each other (1e-9) before timing. Each contender runs in turn,
``rounds`` times (interleaved); the table gives the median wall time per batch as items
per second, items per CPU-second of the process (``time.process_time``: the rate of one
busy core, less sensitive to a loaded machine than wall time), and the ratio to the
Python loop. Then the cold start: seconds from a fresh process's ``import redres`` to the
first ``rr.batch.rate_step`` answer, compiling in the foreground into an empty cache
(cold) and then loading that cache (warm).

Run from the repository root: ``python benchmarks/batch.py [--quick]``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))  # this checkout's redres

from _common import load_text, machine, median, table

import redres as rr

DAMPING = 0.01
LOOP = "Python loop (robot.jacobian + linalg.rate_step)"
SRC = Path(__file__).resolve().parents[1] / "src"


def contenders(robot: rr.Robot, q: np.ndarray, xd: np.ndarray) -> dict[str, Callable[[], object]]:
    """The timed calls; each returns the ``(N, 7)`` joint velocities (but the Jacobians
    alone)."""
    model, data, fid = robot.model, robot.model.createData(), robot.frame_id(None)
    world, eye = pin.LOCAL_WORLD_ALIGNED, DAMPING**2 * np.eye(6)
    J = np.empty((len(q), 6, robot.n))

    def numpy_vectorised() -> object:
        for i in range(len(q)):
            J[i] = pin.computeFrameJacobian(model, data, q[i], fid, world)
        y = np.linalg.solve(J @ J.transpose(0, 2, 1) + eye, xd[..., None])
        return (J.transpose(0, 2, 1) @ y)[..., 0]

    def python_loop() -> object:
        return np.array(
            [rr.linalg.rate_step(robot.jacobian(qi), x, damping=DAMPING).qd for qi, x in zip(q, xd)]
        )

    return {
        "rr.batch.rate_step, 1 thread": lambda: (
            rr.batch.rate_step(robot, q, xd, damping=DAMPING, threads=1).qd
        ),
        "rr.batch.rate_step, 1 thread, return_info=False": lambda: (
            rr.batch.rate_step(robot, q, xd, damping=DAMPING, return_info=False, threads=1).qd
        ),
        f"rr.batch.rate_step, all cores ({os.cpu_count()})": lambda: (
            rr.batch.rate_step(robot, q, xd, damping=DAMPING).qd
        ),
        "NumPy vectorised (Pinocchio loop + batched solve)": numpy_vectorised,
        "rr.batch.jacobian alone, 1 thread (no step)": lambda: rr.batch.jacobian(
            robot, q, threads=1
        ),
        LOOP: python_loop,
    }


def measure(count: int, rounds: int) -> tuple[dict[str, list[tuple[float, float]]], int]:
    robot = rr.models.panda()
    rng = np.random.default_rng(7)
    q = rng.uniform(robot.q_min, robot.q_max, (count, robot.n))
    xd = rng.normal(size=(count, 6))
    calls = contenders(robot, q, xd)
    reference = np.asarray(calls[LOOP]())
    for name, call in calls.items():
        if "jacobian alone" in name:
            continue
        if not np.allclose(np.asarray(call()), reference, rtol=0, atol=1e-9):
            raise SystemExit(f"{name} disagrees with the Python loop")
    samples: dict[str, list[tuple[float, float]]] = {name: [] for name in calls}
    for _ in range(rounds):
        for name, call in calls.items():
            wall, cpu = time.perf_counter(), time.process_time()
            call()
            samples[name].append((time.perf_counter() - wall, time.process_time() - cpu))
    return samples, count


def first_answer(cache: str) -> float:
    """Seconds from a fresh process's import to its first batch answer (foreground)."""
    code = (
        "import time; t = time.perf_counter(); import numpy as np, redres as rr; "
        "robot = rr.models.panda(); q = np.tile(robot.neutral(), (100, 1)); "
        "rr.batch.rate_step(robot, q, np.ones(6), damping=0.01); "
        "print(time.perf_counter() - t)"
    )
    env = dict(os.environ, REDRES_CACHE_DIR=cache, REDRES_COMPILE="foreground")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(SRC), env.get("PYTHONPATH")]))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, check=True, timeout=900)  # fmt: skip
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small batches (a smoke run)")
    parser.add_argument("--items", type=int, default=None, help="items per batch")
    parser.add_argument("--no-cold", action="store_true", help="skip the cold-start timing")
    args = parser.parse_args()
    count = args.items or (2_000 if args.quick else 20_000)
    rounds = 3 if args.quick else 7
    load_before = os.getloadavg()
    samples, count = measure(count, rounds)
    load_after = os.getloadavg()
    loop = median(np.array([w for w, _ in samples[LOOP]]))
    rows = []
    for name, values in samples.items():
        wall = median(np.array([w for w, _ in values]))
        cpu = median(np.array([c for _, c in values]))
        rows.append([name, f"{count / wall:,.0f}", f"{count / cpu:,.0f}",
                     f"{wall / count * 1e9:,.0f}", f"{loop / wall:.0f}x"])  # fmt: skip
    print("## Jacobian + damped least-squares step per item (Panda)\n")
    print(f"{machine()}, Pinocchio {pin.__version__}; {count:,} items per batch, medians of")
    print(f"{rounds} interleaved rounds; {load_text(load_before, load_after)}.\n")
    headers = ["contender", "items/s (wall)", "items per CPU-s", "ns/item (wall)", "vs loop"]
    print(table(headers, rows))
    if args.no_cold:
        return
    with tempfile.TemporaryDirectory(prefix="redres-batch-cold-") as cache:
        cold, warm = first_answer(cache), first_answer(cache)
    print("\nFirst `rr.batch.rate_step` answer in a fresh process (import included), s:\n")
    rows = [["empty (compiles chain, linalg and batch kernels)", f"{cold:.1f}"],
            ["warm (loads them)", f"{warm:.2f}"]]  # fmt: skip
    print(table(["cache", "s"], rows))


if __name__ == "__main__":
    main()
