"""Compile the numba kernels of the hard-limit schemes ahead of use.

``redres demo`` starts this in a second process on a cold start, so that the JIT work of
the QP/SNS kernels overlaps with the first runs on the other core; the compiled code lands
in numba's disk cache, which the demo's own process then loads. If the demo reaches those
runs first it simply compiles them itself.
"""

from __future__ import annotations

import numpy as np

from . import _jit


def compile_hard_limit_kernels() -> None:
    """One step of each hard-limit scheme on the Panda (compiles and caches the kernels)."""
    from .models import panda
    from .resolution import QPScheme, SNSScheme

    robot = panda()
    q = robot.neutral()
    J = robot.jacobian(q)
    for scheme in (SNSScheme(dt=1e-3), QPScheme(dt=1e-3)):
        scheme.step(robot, q, J, np.zeros(6))


if __name__ == "__main__":
    _jit.warmup([("hard-limit kernels (SNS, QP)", compile_hard_limit_kernels)], quiet=True)
