"""
Obstacle avoidance by self-motion
=================================

The Panda holds its hand still while a ball approaches its elbow. The hand task uses six
of the seven joints' worth of freedom; the seventh, the self-motion, is spent on a
hat-shaped penalty of the distance between the arm's link capsules and the ball
(gradient projection, Liégeois 1977; obstacle avoidance by self-motion, Maciejewski &
Klein 1985). Minimum-norm control, which ignores the ball, is the comparison.

Run: python examples/11_obstacle_avoidance.py   (REDRES_EXAMPLE_STEPS shortens it)
"""

# %%
# The scene
# ---------
# The ball starts 25 cm from the elbow's link capsule and moves 20 cm toward it,
# along the line through the capsule's closest point, in the first half of the run.
import os

import matplotlib.pyplot as plt
import numpy as np

import redres as rr
from redres.control import Controller
from redres.objectives import ObstacleObjective, SphereObstacle
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme
from redres.tasks import FrameTask

STEPS = int(os.environ.get("REDRES_EXAMPLE_STEPS", "3000"))
DT = 1e-3
robot = rr.models.panda()
q0 = robot.neutral()
elbow = robot.fk(q0, "elbow")[:3, 3]
away = np.array([0.0, -1.0, 0.0])  # the ball comes from the robot's right
radius = 0.05


def ball(t: float) -> SphereObstacle:
    approach = min(t / (STEPS * DT / 2), 1.0)
    return SphereObstacle(elbow + away * (0.30 - 0.20 * approach), radius, "ball")


def clearance(q: np.ndarray, obstacle: SphereObstacle) -> float:
    """Smallest surface distance between the arm's capsules and the ball, m."""
    return min(p.distance for p in rr.objectives.proximities(robot, q, [obstacle], robot.capsules))


# %%
# Two controllers
# ---------------
# Both hold the hand pose; one also descends the obstacle penalty in the null space.
# The penalty's obstacle list is updated every step with the ball's new position.
def simulate(avoid: bool) -> np.ndarray:
    objective = ObstacleObjective([ball(0.0)], influence=0.2)
    scheme = (
        GradientProjectionScheme([objective], k_null=2.0, damping=0.01)
        if avoid
        else PseudoInverseScheme(damping=0.01)
    )
    task = FrameTask()
    controller = Controller(robot, task, scheme, gain=50.0, dt=DT)
    q, out = q0.copy(), np.empty(STEPS)
    for k in range(STEPS):
        obstacle = ball(k * DT)
        objective.obstacles = [obstacle]
        q = controller.step(q)
        out[k] = clearance(q, obstacle)
    hand_error = np.linalg.norm(robot.fk(q)[:3, 3] - robot.fk(q0)[:3, 3])
    print(f"{'avoiding' if avoid else 'ignoring'}: closest {1e3 * out.min():.1f} mm; "
          f"hand moved {1e3 * hand_error:.3f} mm")  # fmt: skip
    return out


t = np.arange(STEPS) * DT
ignoring, avoiding = simulate(False), simulate(True)

# %%
# Clearance over time
# -------------------
fig, ax = plt.subplots(figsize=(7, 3.6))
ax.plot(t, 1e3 * ignoring, label="minimum norm (ignores the ball)")
ax.plot(t, 1e3 * avoiding, label="gradient projection of the obstacle penalty")
ax.axhline(0.0, color="k", lw=0.8)
ax.set(xlabel="time (s)", ylabel="clearance to the ball (mm)", title="The hand holds still")
ax.legend()
ax.grid(alpha=0.3)
plt.show()
