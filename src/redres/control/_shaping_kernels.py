"""The command shaper's kernel (internal): one control cycle of the jerk-limited velocity
tracker of :mod:`redres.control.shaping`, every joint in one call."""

from __future__ import annotations

import math

from .._compile import kernel


@kernel
def shape(target, limits, dt, synchronized, state, out):
    """``out`` (n) <- the velocities of this cycle, tracking ``target`` (n, rad/s) within
    ``limits`` (3 x n: velocity, acceleration, jerk; ``inf`` where none) at period ``dt``;
    ``state`` (2 x n: the last velocity and acceleration) advanced in place.

    Per joint, with ``h = j_max dt`` the largest change of acceleration in a cycle: the
    acceleration ``a`` is the one after which lowering it by ``h`` a cycle to zero brings
    the velocity exactly to the target (:func:`_landing`), clipped to what the jerk and
    acceleration limits allow from the last one. ``synchronized``: every joint covers the
    same fraction of the way to its target this cycle, the smallest fraction a joint can
    (clipped to the same bounds, so never more than it can). Returns False when
    ``target`` holds NaN or ±inf (then nothing is written)."""
    n = target.shape[0]
    for i in range(n):
        if not math.isfinite(target[i]):
            return False
    fraction = 1.0
    if synchronized:
        for i in range(n):
            goal, landing, lo, hi = _bounds(target, limits, dt, state, i)
            change = goal - state[0, i]
            a = min(max(landing, lo), hi)
            if a != landing and change != 0.0:  # it cannot land this cycle: how far it gets
                fraction = min(fraction, max(a * dt / change, 0.0))
    for i in range(n):
        goal, landing, lo, hi = _bounds(target, limits, dt, state, i)
        v = state[0, i]
        wish = landing if fraction >= 1.0 else fraction * (goal - v) / dt
        a_new = min(max(wish, lo), hi)
        # Landing this cycle (then the acceleration can be zero the next): exactly.
        if a_new == landing and abs(landing) < limits[2, i] * dt:
            v_new = goal
        else:
            v_new = v + a_new * dt
        state[0, i] = v_new
        state[1, i] = a_new
        out[i] = v_new
    return True


@kernel(inline=True)
def _bounds(target, limits, dt, state, i):
    """Joint ``i``'s target within its velocity limit, its landing acceleration, and the
    accelerations its jerk and acceleration limits allow this cycle."""
    v_max, a_max, h = limits[0, i], limits[1, i], limits[2, i] * dt
    a = state[1, i]
    goal = min(max(target[i], -v_max), v_max)
    landing = _landing(goal - state[0, i], h, dt)
    return goal, landing, max(-a_max, a - h), min(a_max, a + h)


@kernel
def _landing(d, h, dt):
    """The acceleration ``a`` that changes the velocity by ``d`` over this cycle and the
    cycles in which ``a`` is lowered by ``h`` each to zero: ``d = dt (a + Σₖ (|a| − k h))``
    over ``k = 1 … ⌊|a|/h⌋`` (with the sign of ``a``). In units of ``h`` and ``h dt``,
    ``x = |a|/h`` and ``D = |d|/(h dt)``: ``D = x + m x − m(m+1)/2`` with ``m = ⌊x⌋``, so
    ``D = m(m+1)/2`` at whole ``x = m`` and ``x = (D + m(m+1)/2)/(m+1)`` between. Without a
    jerk limit (``h`` infinite) the whole change in one cycle, ``d / dt``."""
    if math.isinf(h):
        return d / dt
    D = abs(d) / (h * dt)
    m = math.floor((math.sqrt(1.0 + 8.0 * D) - 1.0) / 2.0)
    if (m + 1) * (m + 2) / 2.0 <= D:  # the square root rounded low
        m += 1
    elif m * (m + 1) / 2.0 > D:  # or high
        m -= 1
    x = (D + m * (m + 1) / 2.0) / (m + 1)
    return math.copysign(h * x, d)
