"""Per-call cost of one operational-space control step on the Panda (not a test).

Run from the repository root::

    python benchmarks/dynamics.py [--rounds 21] [--calls 500]

Times ``OperationalSpaceController.step`` (6-D task at the TCP, posture objective in the
null space) with each projector — the dynamic one compiled (one kernel call,
:mod:`redres.dynamics.chain`; its inverse's singular values computed only when the
step's ``info`` is read: a second row reads it) and on its Pinocchio path —, the acceleration-level
controller, and the pieces one step is made of (the Robot calls into Pinocchio, the
compiled terms, the inverse, the bare-array torque law), plus one semi-implicit Euler step
of the simulator (ABA). Cases are interleaved in
shuffled order in every round; the table reports the median over rounds of the mean time
per call, so that drifts of the machine load affect all cases alike.
"""

from __future__ import annotations

import argparse
import os
import platform
import random
import statistics
import sys
import time
from collections.abc import Callable

import numpy as np

try:
    import redres as rr
except ImportError:  # not installed: run from a source checkout
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
    import redres as rr

from redres.dynamics import (
    AccelerationController,
    OperationalSpaceController,
    operational_space_torque,
)
from redres.dynamics.chain import ChainDynamics
from redres.linalg import dynamically_consistent_pinv, generalized_inverse
from redres.objectives import PostureObjective


def cases() -> dict[str, Callable[[], object]]:
    """The timed calls, at one state of the Panda near its ready pose."""
    robot = rr.models.panda()
    q_ref = robot.neutral()
    rng = np.random.default_rng(3)
    q = q_ref + rng.uniform(-0.1, 0.1, robot.n)
    qd = rng.uniform(-0.5, 0.5, robot.n)
    target = robot.fk(q_ref)
    laws = {
        "osc step (dynamic)": OperationalSpaceController(objectives=[PostureObjective(q_ref)]),
        "osc step (dynamic, Pinocchio path)": OperationalSpaceController(
            objectives=[PostureObjective(q_ref)]
        ),
        "osc step (kinematic)": OperationalSpaceController(
            objectives=[PostureObjective(q_ref)], projector="kinematic"
        ),
        "acceleration step (dynamic)": AccelerationController(objectives=[PostureObjective(q_ref)]),
    }
    for law in laws.values():
        law.task.set_target(target)
        law.reset()
    laws["osc step (dynamic, Pinocchio path)"]._compiled = (robot, None)  # type: ignore[attr-defined]
    chain = ChainDynamics(robot)
    J, M, b = robot.jacobian(q), robot.mass_matrix(q), robot.bias(q, qd)
    a, tau0 = rng.normal(size=6), rng.normal(size=robot.n)
    zero = np.zeros(robot.n)
    out: dict[str, Callable[[], object]] = {
        name: (lambda law=law: law.step(robot, q, qd)) for name, law in laws.items()
    }
    dynamic = laws["osc step (dynamic)"]
    out["osc step (dynamic), info read"] = lambda: dynamic.step(robot, q, qd).info
    out.update(
        {
            "  robot.kinematics": lambda: robot.kinematics(q),
            "  robot.jacobian_dot": lambda: robot.jacobian_dot(q, qd),
            "  robot.mass_matrix": lambda: robot.mass_matrix(q),
            "  robot.bias": lambda: robot.bias(q, qd),
            "  ChainDynamics.terms (all five, compiled)": lambda: chain.terms(q, qd),
            "  J_bar (generalized_inverse, W=M)": lambda: generalized_inverse(
                J, weights=M, return_info=True
            ),
            "  J_bar (dynamically_consistent_pinv)": lambda: dynamically_consistent_pinv(
                J, M, return_info=True
            ),
            "  operational_space_torque (bare)": lambda: operational_space_torque(J, M, b, a, tau0),
            "sim step (ABA + Euler)": lambda: (
                q + 1e-3 * (qd + 1e-3 * robot.forward_dynamics(q, qd, zero))
            ),
        }
    )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=21)
    parser.add_argument("--calls", type=int, default=500)
    args = parser.parse_args()
    timed = cases()
    for fn in timed.values():  # warm up (numba kernels, caches)
        fn()
    samples: dict[str, list[float]] = {name: [] for name in timed}
    names = list(timed)
    for _ in range(args.rounds):
        random.shuffle(names)
        for name in names:
            fn = timed[name]
            t0 = time.perf_counter_ns()
            for _ in range(args.calls):
                fn()
            samples[name].append((time.perf_counter_ns() - t0) / args.calls / 1e3)
    print(
        f"# {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
        f"numpy {np.__version__}; {args.rounds} rounds x {args.calls} calls; load average "
        f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}"
    )
    print(f"{'case':40s} {'median us':>10s} {'min us':>8s}")
    for name in timed:
        print(f"{name:40s} {statistics.median(samples[name]):10.1f} {min(samples[name]):8.1f}")


if __name__ == "__main__":
    main()
