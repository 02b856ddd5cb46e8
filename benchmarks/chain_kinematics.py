"""Forward kinematics + world-aligned Jacobian of the tip: compiled chain vs Pinocchio.

For the Panda (TCP) and the iiwa 14 (flange), times one call that yields the tip pose
(4x4) and its world-aligned geometric Jacobian (6 x 7, Pinocchio ``LOCAL_WORLD_ALIGNED``):

* ``redres.robot.chain`` kernel: the native entry point of ``jacobian`` with the chain's
  arrays and preallocated outputs (the hot-path form the fused step and IK will use);
* ``SerialChain.kinematics``: the checked public call (validates ``q``, allocates);
* Pinocchio ``framesForwardKinematics`` + ``computeJointJacobians`` + ``getFrameJacobian``;
* Pinocchio ``computeFrameJacobian`` + ``updateFramePlacement`` (what
  ``Robot.placement_jacobian`` does for ``reference="world"``);
* ``robot.fk(q)`` + ``robot.jacobian(q)`` and ``robot.kinematics(q)`` (public API).

A second table gives the kernel's cost where the fused step and compiled IK will call
it, inside compiled code (a numba loop of calls, no Python between them), and the checked
``pose_error`` call.

All results are checked equal (1e-12) before timing. Cases are interleaved in every round
(``_common.interleaved``) and the table gives the median per call and each case's time
divided by the compiled kernel's (> 1: the kernel is faster), with the load average.

Run from the repository root: ``python benchmarks/chain_kinematics.py [--quick]``.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))  # this checkout's redres

from _common import interleaved, load_text, machine, median, table

import redres as rr

ARMS = ("panda", "iiwa14")
KERNEL = "chain kernel (entry point, outputs given)"


def cases(robot: rr.Robot, q: np.ndarray) -> dict[str, Callable[[], object]]:
    """The timed calls; each yields the tip pose and world-aligned Jacobian."""
    model, data, fid = robot.model, robot.model.createData(), robot.frame_id(None)
    chain = robot.chain()
    arrays, entry = chain.arrays, chain.kernel("jacobian")
    T, J = np.empty((4, 4)), np.empty((6, robot.n))
    world = pin.LOCAL_WORLD_ALIGNED

    def kernel() -> object:
        entry(*arrays, q, False, T, J)
        return T, J

    def pin_three_calls() -> object:
        pin.framesForwardKinematics(model, data, q)
        pin.computeJointJacobians(model, data, q)
        return data.oMf[fid].homogeneous, pin.getFrameJacobian(model, data, fid, world)

    def pin_frame_jacobian() -> object:
        jac = pin.computeFrameJacobian(model, data, q, fid, world)
        return pin.updateFramePlacement(model, data, fid).homogeneous, jac

    return {
        KERNEL: kernel,
        "SerialChain.kinematics(q) (checked)": lambda: chain.kinematics(q),
        "pin framesForwardKinematics + computeJointJacobians + getFrameJacobian": (pin_three_calls),
        "pin computeFrameJacobian + updateFramePlacement (Robot's path)": pin_frame_jacobian,
        "robot.fk(q) + robot.jacobian(q)": lambda: (robot.fk(q), robot.jacobian(q)),
        "robot.kinematics(q)": lambda: robot.kinematics(q),
    }


def check(robot: rr.Robot, q: np.ndarray) -> None:
    """Every case gives Pinocchio's pose and Jacobian before anything is timed."""
    expected = (robot.fk(q), robot.jacobian(q))
    for name, fn in cases(robot, q).items():
        got = fn()
        assert isinstance(got, tuple)
        for value, ref in zip(got, expected, strict=True):
            if not np.allclose(np.asarray(value).reshape(ref.shape), ref, rtol=0, atol=1e-12):
                raise SystemExit(f"{robot.name}: {name} disagrees with Pinocchio")


def measure(arm: str, rounds: int, batch: int) -> dict[str, float]:
    robot = rr.models.load(arm)
    q = robot.random_configuration(np.random.default_rng(7))
    check(robot, q)
    samples = interleaved(cases(robot, q), rounds=rounds, batch=batch, batches=5)
    return {name: median(values) for name, values in samples.items()}


def in_compiled_code(arm: str, calls: int = 200_000) -> tuple[float, float]:
    """µs per call of the ``jacobian`` and ``pose_error`` kernels from a compiled loop
    (best of 5 loops: the least disturbed by the rest of the machine)."""
    import numba

    from redres import _compile
    from redres.robot.chain import KERNELS

    _compile.compile_on_first_use()  # the compiled module, not its twin while compiling behind
    kernels = KERNELS.module()
    assert kernels is not None
    jacobian, pose_error = kernels.jacobian, kernels.pose_error  # what compiled code calls
    robot = rr.models.load(arm)
    links, axes, kinds = robot.chain().arrays
    q = robot.random_configuration(np.random.default_rng(7))
    target = robot.fk(robot.random_configuration(np.random.default_rng(8)))
    T, J, e = np.empty((4, 4)), np.empty((6, robot.n)), np.empty(6)

    @numba.njit  # type: ignore[misc]
    def jacobian_loop(links, axes, kinds, q, T, J, calls):  # type: ignore[no-untyped-def]
        for _ in range(calls):
            q[0] += 1e-12  # a new configuration every call
            jacobian(links, axes, kinds, q, False, T, J)

    @numba.njit  # type: ignore[misc]
    def error_loop(links, axes, kinds, q, target, T, J, e, calls):  # type: ignore[no-untyped-def]
        for _ in range(calls):
            q[0] += 1e-12
            pose_error(links, axes, kinds, q, target, T, J, e)

    def best(run: Callable[[int], object]) -> float:
        run(10)
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            run(calls)
            times.append((time.perf_counter() - t0) / calls * 1e6)
        return min(times)

    return (
        best(lambda c: jacobian_loop(links, axes, kinds, q, T, J, c)),
        best(lambda c: error_loop(links, axes, kinds, q, target, T, J, e, c)),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="few rounds (a smoke run)")
    args = parser.parse_args()
    rounds, batch = (3, 50) if args.quick else (15, 400)
    load_before = os.getloadavg()
    results = {arm: measure(arm, rounds, batch) for arm in ARMS}
    load_after = os.getloadavg()
    rows = []
    for name in results[ARMS[0]]:
        row = [name]
        for arm in ARMS:
            value, ours = results[arm][name], results[arm][KERNEL]
            row += [f"{value:.2f}", f"{value / ours:.1f}x"]
        rows.append(row)
    headers = ["case"] + [f"{arm} {what}" for arm in ARMS for what in ("µs", "÷ kernel")]
    print("## Tip pose + world-aligned Jacobian: compiled chain vs Pinocchio\n")
    print(f"{machine()}, Pinocchio {pin.__version__}; medians of {rounds} interleaved rounds")
    print(f"x 5 batches x {batch} calls; {load_text(load_before, load_after)}.\n")
    print(table(headers, rows))
    compiled = {arm: in_compiled_code(arm) for arm in ARMS}
    print("\nInside compiled code (a numba loop of calls; best of 5 x 200,000), µs per call:\n")
    print(
        table(
            ["kernel", *ARMS],
            [
                ["jacobian (pose + world Jacobian)", *(f"{compiled[a][0]:.3f}" for a in ARMS)],
                ["pose_error (pose + Jacobian + error)", *(f"{compiled[a][1]:.3f}" for a in ARMS)],
            ],
        )
    )


if __name__ == "__main__":
    main()
