"""``redres demo``: the built-in robots and worked examples from the seed documents.

This is the demo of the foundation release; the side-by-side comparison of schemes joins
it as those land.
"""

from __future__ import annotations

import json

import numpy as np

from . import linalg, models

DEG = np.pi / 180


def worked_examples() -> list[dict[str, object]]:
    """Seed 002's numeric examples and one null-space step on the Panda, computed live."""
    out: list[dict[str, object]] = []
    rrr = models.planar([1.0, 1.0, 1.0])
    J = rrr.jacobian(np.array([60.0, -30.0, 15.0]) * DEG)[:2]
    J_printed = np.round(J, 2)  # the seed computes with its Jacobian rounded to 2 decimals
    for weights in ([1.0, 2.0, 3.0], [3.0, 2.0, 1.0]):
        W = np.diag(weights)
        v = np.array([1.0, 1.0])
        out.append(
            {
                "example": "seed 002: RRR at (60, -30, 15) deg, v = (1, 1) m/s, "
                f"W = diag{tuple(weights)}",
                "qd_rad_s": np.round(linalg.weighted_pinv(J_printed, W) @ v, 2).tolist(),
                "qd_exact_jacobian_rad_s": np.round(linalg.weighted_pinv(J, W) @ v, 4).tolist(),
            }
        )
    rr_arm = models.planar([1.0, 1.0])
    J = rr_arm.jacobian(np.array([30.0, 30.0]) * DEG)[[0, 1, 5]]
    for v in ([1.0, 1.0, 1.0], [-2.0, 2.0, 2.0]):
        qd = linalg.left_pinv(J) @ np.array(v)
        out.append(
            {
                "example": f"seed 002: RR at (30, 30) deg, left pseudo-inverse, v = {tuple(v)}",
                "qd_rad_s": np.round(qd, 3).tolist(),
                "achieved_x": np.round(J @ qd, 3).tolist(),
            }
        )
    J = rr_arm.jacobian(np.array([30.0, 0.0]) * DEG)[:2]
    qd = linalg.pinv(J) @ np.array([-1.0, np.sqrt(3.0)])
    out.append(
        {
            "example": "seed 002: singular RR at (30, 0) deg, SVD pseudo-inverse, v = (-1, sqrt 3)",
            "qd_rad_s": np.round(qd, 3).tolist(),
        }
    )
    panda = models.panda()
    q = panda.neutral()
    J = panda.jacobian(q)
    v = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    mid = (panda.q_min + panda.q_max) / 2
    grad = 2 * (q - mid) / (panda.q_min - panda.q_max) ** 2  # seed 003's cost D(q)
    J_pinv = linalg.right_pinv(J)
    N = linalg.nullspace_projector(J, J_pinv)
    qd = J_pinv @ v - 1.0 * N @ grad
    out.append(
        {
            "example": "seed 000/003: Panda at its ready pose, v = 0.1 m/s along x, "
            "joint-limit gradient projected into the null space (k = 1)",
            "qd_rad_s": np.round(qd, 4).tolist(),
            "task_residual": float(np.linalg.norm(J @ qd - v)),
            "manipulability": float(linalg.manipulability(J)),
        }
    )
    return out


def run_demo(*, quiet: bool = False, as_json: bool = False) -> int:
    """Print the built-in robots and the worked examples; returns the exit code."""
    from .cli import robots_table

    table, records = robots_table()
    examples = worked_examples()
    if as_json:
        print(json.dumps({"robots": records, "examples": examples}))
        return 0
    if not quiet:
        print("redres: redundancy resolution for robot manipulators\n")
        print("Built-in robots (redres robots):")
    print(table)
    print()
    if not quiet:
        print("Worked examples, computed now:")
    for ex in examples:
        print(f"- {ex['example']}")
        for key, value in ex.items():
            if key != "example":
                print(f"    {key}: {value}")
    return 0
