"""The analytic IK kernel's packed constants, flags and tolerances, read by the kernel
(:mod:`._analytic_kernels`) and its caller (:mod:`.analytic`).

The arm's constants cross the Python → kernel boundary as one flat float64 array of
:data:`N_ARM` slots (points in m, unit vectors, the elbow law's coefficients): slot
``S`` holds the shoulder point's three coordinates, and so on (:mod:`.analytic` derives
each). A kernel compiles these values in, so this module is covered by the cache stamp
(its name: ``_*_codes.py``).
"""

from __future__ import annotations

from enum import IntEnum, IntFlag


class AnalyticFlag(IntFlag):
    """What is special about a solution, or a pose (the union over its solutions).

    - ``SHOULDER_SINGULAR``: axes 1 and 3 are aligned (``sin`` of their angle below
      :data:`SINGULAR_TOL`): only ``q1 ± q3`` is determined; the solution splits it
      evenly, and only one of the two shoulder branches is returned.
    - ``ELBOW_STRETCHED``: ``|W − S|`` is at an extreme of its law in ``q4`` (the two
      elbow roots merge, within :data:`MERGE_TOL`): one elbow root is returned.
    - ``BRANCHES_MERGED``: the two roots of the joint-5/6 angle condition merge (within
      :data:`MERGE_TOL`): one is returned.
    - ``SELF_MOTION``: the condition does not fix the rotation about ``S → W`` (the
      joint-5 axis or the joint-6 axis along ``S → W``, or ``W`` at ``S``): a continuum
      of solutions, of which one is returned.
    - ``UNREACHABLE``: no solution (the pose, at this ``q7``, is out of reach).
    """

    SHOULDER_SINGULAR = 1
    ELBOW_STRETCHED = 2
    BRANCHES_MERGED = 4
    SELF_MOTION = 8
    UNREACHABLE = 16


class AnalyticStatus(IntEnum):
    """How the kernel treated its input (negative: refused, nothing solved)."""

    SOLVED = 0  # solved: zero to eight solutions
    BAD_POSE = -1  # the pose is not finite or its 3x3 block is not a rotation
    BAD_Q7 = -2  # q7 is not finite


#: Flag values as plain ints, for the kernel.
SHOULDER_SINGULAR = int(AnalyticFlag.SHOULDER_SINGULAR)
ELBOW_STRETCHED = int(AnalyticFlag.ELBOW_STRETCHED)
BRANCHES_MERGED = int(AnalyticFlag.BRANCHES_MERGED)
SELF_MOTION = int(AnalyticFlag.SELF_MOTION)
UNREACHABLE = int(AnalyticFlag.UNREACHABLE)
SOLVED, BAD_POSE, BAD_Q7 = (int(s) for s in AnalyticStatus)

#: Most solutions of one pose: 2 elbow roots x 2 roots of the 5/6 condition x 2 shoulders.
MAX_SOLUTIONS = 8
#: Columns of the per-solution codes: branch, flags, within the limits (0/1).
BRANCH, FLAGS, WITHIN = 0, 1, 2
N_CODES = 3
#: Joints of the arms covered.
N_JOINTS = 7
#: Columns of the per-solution values: the joints (:data:`N_JOINTS`, rad), then the
#: solution's own FK error: position (m), rotation angle (rad).
POSITION_ERROR, ROTATION_ERROR = N_JOINTS, N_JOINTS + 1
N_VALUES = N_JOINTS + 2

# Slots of the ``arm`` array (start of each 3-vector, or the scalar).
S = 0  # shoulder point, world, m
W6 = 3  # wrist point W (axes 5 and 6 meet) in frame 6, m
SP = 6  # S in the placement frame of joint 4 (before its rotation), m
W4 = 9  # W in frame 4, m
Z5 = 12  # joint-5 axis in frame 4
K1 = 15  # shoulder axes at zero, in the placement frame of joint 1 (k1 = its axis)
K2 = 18
K3 = 21
M3 = 24  # a unit vector perpendicular to k3 (same frame)
M3C = 27  # the same vector in frame 3: Cᵀ m, C = R(links[1]) R(links[2])
BA5 = 30  # joint-6 axis in frame 5, R(links[5]) a5
BTA4 = 33  # joint-5 axis in frame 6, R(links[5])ᵀ a4
ELBOW = 36  # K, P, A, B: |W − S|² = K − 2 (P + A cos q4 + B sin q4)
COS_GAMMA = 40  # cosine of the fixed angle between the joint-5 and joint-6 axes
N_ARM = 41

#: A pose's 3x3 block must be a rotation to this tolerance (max |RᵀR − I| entry), its
#: last row ``[0, 0, 0, 1]`` to :data:`HOMOGENEOUS_TOL` (the checks of ``as_transform``).
ROTATION_TOL = 1e-6
HOMOGENEOUS_TOL = 1e-9
#: The arguments of the acos of the elbow law and of the 5/6 condition may exceed 1 by
#: this much (rounding at the edge of the workspace) and are clamped; beyond: no root.
REACH_TOL = 1e-10
#: Two roots ``δ ± acos(x)`` merge into one when ``1 − |x|`` is below this.
MERGE_TOL = 1e-12
#: Axes 1 and 3 count as aligned below this sine of their angle; the rotation about
#: ``S → W`` is free below this product of the perpendicular parts (module docstrings).
SINGULAR_TOL = 1e-12
#: A joint within its limits up to this much, rad.
LIMIT_TOL = 1e-12
