"""
Gradient projection keeps the joints inside their limits
========================================================

The Panda circle that drives minimum-norm control into a joint limit, with and without
the joint-limit cost projected into the null space (Liégeois 1977).

Run: python examples/03_gradient_projection.py   (REDRES_EXAMPLE_STEPS shortens it)
"""

from __future__ import annotations

import os

import redres as rr
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme, WeightedLeastNormScheme
from redres.scenarios.spec import builtin
from redres.tasks import FrameTask


def main() -> None:
    scenario = builtin("panda_joint_limit_circle")
    steps = int(os.environ.get("REDRES_EXAMPLE_STEPS", "10000"))
    schemes = [
        PseudoInverseScheme(),
        GradientProjectionScheme([JointLimitObjective()], k_null=5.0),
        WeightedLeastNormScheme(),
    ]
    print(scenario.description)
    for scheme in schemes:
        log = rr.run(
            scenario.robot,
            FrameTask(),
            scenario.trajectory,
            scheme,
            q0=scenario.q0,
            dt=1e-3,
            duration=steps * 1e-3,
            gain=50.0,
        )
        s = log.summary()
        print(
            f"{scheme.name:20s} max error {s['max_position_error_m'] * 1e3:.4f} mm, "
            f"min joint-limit margin {s['min_joint_limit_margin_rad']:+.3f} rad"
        )


if __name__ == "__main__":
    main()
