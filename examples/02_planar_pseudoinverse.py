"""
Textbook inverses on planar arms
================================

The textbook inverses on the planar RR and RRR arms with unit links.

Run: python examples/02_planar_pseudoinverse.py
"""

from __future__ import annotations

import numpy as np

import redres as rr

DEG = np.pi / 180


def main() -> None:
    rrr = rr.models.planar([1.0, 1.0, 1.0])
    J = rrr.jacobian(np.array([60, -30, 15]) * DEG)[:2]  # (x, y) rows
    v = np.array([1.0, 1.0])
    for W in (np.diag([1.0, 2.0, 3.0]), np.diag([3.0, 2.0, 1.0])):
        qd = rr.linalg.weighted_pinv(J, W) @ v
        print(f"RRR, W = diag{tuple(np.diag(W))}: qd = {np.round(qd, 3)} rad/s, J qd = {J @ qd}")

    arm = rr.models.planar([1.0, 1.0])
    J = arm.jacobian(np.array([30, 30]) * DEG)[[0, 1, 5]]  # (x, y, phi): 3 x 2
    qd = rr.linalg.left_pinv(J) @ np.array([1.0, 1.0, 1.0])
    print(f"RR, left pseudo-inverse: qd = {np.round(qd, 3)}, achieved {np.round(J @ qd, 3)}")

    J = arm.jacobian(np.array([30, 0]) * DEG)[:2]  # singular: the arm is stretched
    J_pinv, info = rr.linalg.pinv(J, return_info=True)
    print(f"RR stretched: rank {info.rank}, sigma_min {info.sigma_min:.2e}")
    print("SVD pseudo-inverse:\n", np.round(J_pinv, 3))
    print("qd for v = (-1, sqrt 3):", np.round(J_pinv @ [-1.0, np.sqrt(3.0)], 3))


if __name__ == "__main__":
    main()
