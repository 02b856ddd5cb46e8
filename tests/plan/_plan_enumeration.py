"""Exhaustive enumeration of a path grid's admissible paths, the oracle of the DP tests:
every transition test written here from its definition, independently of the kernels."""

from __future__ import annotations

import numpy as np

import redres as rr
from redres.plan import PathGrid


def admissible_paths(grid: PathGrid, delta: np.ndarray, accel: np.ndarray | None = None,
                     start: tuple[int, int] | None = None
                     ) -> tuple[list[np.ndarray], np.ndarray]:  # fmt: skip
    """Every admissible path of ``grid``: per sample the configurations of its feasible
    nodes ``(N_k, n)``, and the paths ``(count, K)`` as indices into them. A step is
    admissible when every joint moves at most ``delta``; with ``accel``, also when every
    central second difference ``|q_{k+1} − 2 q_k + q_{k−1}|`` is at most ``accel``.
    ``start``: the only node allowed at the first sample."""
    K = len(grid.q)
    nodes = []
    for k in range(K):
        mask = grid.feasible[k].copy()
        if k == 0 and start is not None:
            keep = mask[start]
            mask[:] = False
            mask[start] = keep
        nodes.append(grid.q[k][mask])  # (N_k, n), rows in (p, b) order
    paths = np.arange(len(nodes[0]))[:, None]
    for k in range(1, K):
        step = np.abs(nodes[k][None, :, :] - nodes[k - 1][:, None, :])
        allowed = np.all(step <= delta, axis=2)  # (N_{k-1}, N_k)
        rows, cols = np.nonzero(allowed[paths[:, -1]])
        if accel is not None and k >= 2:
            q0, q1 = nodes[k - 2][paths[rows, -2]], nodes[k - 1][paths[rows, -1]]
            steady = np.all(np.abs(nodes[k][cols] - 2.0 * q1 + q0) <= accel, axis=1)
            rows, cols = rows[steady], cols[steady]
        paths = np.concatenate((paths[rows], cols[:, None]), axis=1)
    return nodes, paths


def margins(robot: rr.Robot, q: np.ndarray) -> np.ndarray:
    """The smallest joint-limit margin of each configuration, rad."""
    return np.minimum(q - robot.q_min, robot.q_max - q).min(axis=-1)


def sequential_sums(nodes: list[np.ndarray], paths: np.ndarray, node_cost: list[np.ndarray],
                    edge_weight: float) -> np.ndarray:  # fmt: skip
    """Each path's ``Σ`` in path order, ``V ← (V + e) + c``, the DP's order of additions;
    the step norm summed joint by joint in order."""
    total = node_cost[0][paths[:, 0]].copy()
    for k in range(1, paths.shape[1]):
        d = nodes[k][paths[:, k]] - nodes[k - 1][paths[:, k - 1]]
        ss = np.zeros(len(paths))
        for c in range(d.shape[1]):
            ss = ss + d[:, c] * d[:, c]
        total = (total + edge_weight * np.sqrt(ss)) + node_cost[k][paths[:, k]]
    return total
