"""
Robot models: poses, Jacobians and dynamics
===========================================

Load a robot, ask it for poses, Jacobians and dynamics.

Run: python examples/01_robot_models.py
"""

from __future__ import annotations

import numpy as np

import redres as rr


def main() -> None:
    print("built-in robots:", rr.models.names())
    robot = rr.models.panda()
    q = robot.neutral()
    T = robot.fk(q)  # pose of the TCP in the world
    J = robot.jacobian(q)  # 6 x 7, rows [v; w], world-aligned axes at the TCP
    print(f"{robot}: TCP at {np.round(T[:3, 3], 4)} m")
    print("Jacobian singular values:", np.round(np.linalg.svd(J, compute_uv=False), 4))
    qd = np.full(robot.n, 0.1)
    print("TCP twist for qd = 0.1 rad/s each:", np.round(J @ qd, 4))
    print("gravity torques at the ready pose (N m):", np.round(robot.gravity(q), 3))
    M = robot.mass_matrix(q)
    print("mass matrix diagonal (kg m^2):", np.round(np.diag(M), 4))
    print("joint-limit margins (rad):", np.round(robot.joint_limit_margin(q), 3))


if __name__ == "__main__":
    main()
