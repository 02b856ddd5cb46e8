"""
The augmented Jacobian holds the arm angle
==========================================

The augmented Jacobian holds the arm angle of the iiwa14 (Kreutz-Delgado et al. 1992).

Run: python examples/04_augmented_arm_angle.py   (REDRES_EXAMPLE_STEPS shortens it)
"""

from __future__ import annotations

import os

import numpy as np

import redres as rr
from redres.resolution import AugmentedJacobianScheme, PseudoInverseScheme
from redres.scenarios.spec import builtin
from redres.tasks import ArmAngleTask, FrameTask


def main() -> None:
    scenario = builtin("iiwa_arm_angle_eight")
    steps = int(os.environ.get("REDRES_EXAMPLE_STEPS", "10000"))
    arm = ArmAngleTask()
    phi0 = arm.value(scenario.robot, scenario.q0)
    print(scenario.description)
    print(f"arm angle at the start: {np.degrees(phi0):.3f} deg")
    for scheme in (PseudoInverseScheme(), AugmentedJacobianScheme()):
        log = rr.run(
            scenario.robot,
            FrameTask(),
            scenario.trajectory,
            scheme,
            q0=scenario.q0,
            duration=steps * 1e-3,
        )
        phis = np.array([arm.value(scenario.robot, q) for q in log.q[::20]])
        print(
            f"{scheme.name:10s} max error {log.summary()['max_position_error_m'] * 1e3:.4f} mm, "
            f"arm angle drift {np.degrees(np.abs(phis - phi0).max()):.4f} deg"
        )


if __name__ == "__main__":
    main()
