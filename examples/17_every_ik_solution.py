"""
Every IK solution of a pose, and its self-motion
================================================

Numerical IK finds one configuration; a 7-DOF arm reaches a pose in a whole curve of
them. ``rr.ik_all`` returns every configuration at one value of the last joint ``q7`` (up
to eight: the elbow root, the root of the wrist condition and the shoulder sign), in a
few microseconds, by the closed form of arms with a spherical shoulder whose axes 5 and 6
meet (He & Liu 2021 for the Franka Panda; the iiwa14 too). ``rr.self_motion`` gives, per
branch, the values of ``q7`` for which that solution stays within the joint limits: where
the tool can stay while the elbow moves.

Run: python examples/17_every_ik_solution.py
"""

# %%
# Every solution at one q7
# ------------------------
import time

import matplotlib.pyplot as plt
import numpy as np

import redres as rr

robot = rr.models.panda()
q_true = np.array([0.3, -0.4, 0.2, -2.0, 0.1, 1.8, 0.6])
T = robot.fk(q_true)
found = rr.ik_all(robot, T, q7=q_true[6])
print(f"{found.count} solutions at q7 = {q_true[6]} rad; {found.within_limits.sum()} within limits")
for q, b, ok in zip(found.q, found.branch, found.within_limits):
    print(f"  branch {b}  {'within limits' if ok else 'outside     '}  {np.round(q, 3)}")
assert np.min(np.abs(found.q - q_true).max(axis=1)) < 1e-9

start = time.perf_counter()
for _ in range(2000):
    rr.ik_all(robot, T, q7=q_true[6])
print(f"{(time.perf_counter() - start) / 2000 * 1e6:.1f} us per call")

# %%
# The self-motion along q7
# ------------------------
# Each branch within the limits is one or more intervals of q7. Sampled along them, the
# elbow (joint 4) and the shoulder (joint 2) move while the hand stays put.
motion = rr.self_motion(robot, T, parameter="q7")
for b, arcs in enumerate(motion.intervals):
    if arcs:
        print(f"branch {b}: q7 in " + ", ".join(f"[{lo:.3f}, {hi:.3f}]" for lo, hi in arcs))
values, configs, branches = motion.sample(per_radian=50)
worst = max(np.abs(robot.fk(q) - T).max() for q in configs)
print(f"{len(configs)} configurations along the self-motion, worst pose error {worst:.1e}")

fig, ax = plt.subplots(figsize=(6.5, 3.2))
for b in np.unique(branches):
    pick = branches == b
    ax.plot(values[pick], configs[pick, 3], ".", ms=3, label=f"q4, branch {b}")
    ax.plot(values[pick], configs[pick, 1], "x", ms=3, label=f"q2, branch {b}")
ax.axvline(q_true[6], color="0.5", lw=0.8, ls="--")
ax.set_xlabel("q7 (rad)")
ax.set_ylabel("joint angle (rad)")
ax.set_title("The Panda holds one pose: elbow and shoulder along its self-motion")
ax.legend(fontsize=7)
fig.tight_layout()
plt.show()
