"""The analytic IK kernels' packed constants, flags and tolerances, read by the kernels
(:mod:`._q7_kernels`, :mod:`._arm_angle_kernels`, their shared :mod:`._geometry_kernels`,
:mod:`._residual_kernels`, :mod:`._nearest_kernels`) and their caller (:mod:`.analytic`).

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
#: ``rr.ik``'s closed-form answer (:mod:`._nearest_kernels`): no value of ``q7`` tried has a
#: solution within the limits.
NONE_WITHIN_LIMITS = -3

#: Most solutions of one pose: 2 elbow roots x 2 roots of the 5/6 condition x 2 shoulders.
MAX_SOLUTIONS = 8
#: Joints of the arms covered.
N_JOINTS = 7
#: Columns of a pose's buffer ``(N_ROWS, N_VALUES)`` float64: per solution (rows 0 to
#: ``count − 1``) the joints (:data:`N_JOINTS`, rad), its own FK error: position (m),
#: rotation angle (rad) (filled by ``errors``, not by ``solve_pose``), then its branch
#: code, flags and whether it is within the limits (1.0 or 0.0), as floats.
POSITION_ERROR, ROTATION_ERROR = N_JOINTS, N_JOINTS + 1
BRANCH, FLAGS, WITHIN = N_JOINTS + 2, N_JOINTS + 3, N_JOINTS + 4
N_VALUES = N_JOINTS + 5
#: The buffer's last row: the pose solved, ``T[:3, :4]`` row by row (12 values, the
#: reference of the FK errors).
POSE = MAX_SOLUTIONS
#: The row after it: the arguments of the ``acos`` that decide which branches exist (a
#: root exists where its argument lies within ±1): the elbow's ``x`` (step 2 of
#: :mod:`.analytic`) in column 0 and, in column ``1 + i4``, the joint-5/6 condition's ``y``
#: of elbow root ``i4`` (step 3); NaN where not reached (the elbow out of reach, one
#: elbow root, or a condition that does not involve the angle about ``S → W``).
ROOTS = MAX_SOLUTIONS + 1
N_ROWS = MAX_SOLUTIONS + 2
#: ``solve_pose`` returns one int: a negative :class:`AnalyticStatus`, or
#: ``count + (flags << FLAG_SHIFT)`` when solved; ``COUNT_MASK`` takes the count.
FLAG_SHIFT = 4
COUNT_MASK = (1 << FLAG_SHIFT) - 1

# Slots of the ``arm`` array (start of each vector or 3x3 matrix, row by row, or the
# scalar); frames and the derivation in :mod:`.analytic`, ``R(X)`` the rotation of a
# placement ``X = links[j]``, ``a_j`` the axis of joint ``j`` (1-based).
# frame 6: R6 = R_T (M0 + cos q7 MC + sin q7 MS), M(q7) = R(X7)ᵀ Rot(a7, −q7) R(X6)ᵀ
M0, MC, MS = 0, 9, 18
D7 = 27  # −R(X7)ᵀ p(X7): the origin of frame 7 is p_T + R_T D7, m
WE = 30  # W − p(X6) in frame 6: W = p_T + R_T D7 + R6 WE, m
A6 = 33  # the joint-6 axis in frame 6
S = 36  # shoulder point, world, m
# the elbow: |W − S|² = K − 2 (P + A cos q4 + B sin q4) = K − 2 P − 2 H cos(q4 − δ)
K_ELBOW, P_ELBOW = 39, 40
INV_H = 41  # 1 / H, H = hypot(A, B), 1/m²
DELTA, COS_DELTA, SIN_DELTA = 42, 43, 44  # δ = atan2(B, A), rad; its cosine and sine
# S → W in frame 3: v3 = V0 + cos q4 VC + sin q4 VS (m); the joint-5 axis there:
# u3 = U0 + cos q4 UC + sin q4 US
V0, VC, VS = 45, 48, 51
U0, UC, US = 54, 57, 60
# q5 = atan2(r·(Gᵀ P5), r·(Gᵀ Q5)), r = R3ᵀ z6 (frame 3), Gᵀ = R(X3) Rot(a4, q4) R(X4)
# (frame 4 to frame 3): Gᵀ P5 = P50 + cos q4 P5C + sin q4 P5S, likewise Q5
P50, P5C, P5S = 63, 66, 69
Q50, Q5C, Q5S = 72, 75, 78
# q6 = atan2(z5·(R6 P6), z5·(R6 Q6)) (frame 6 vectors)
P6, Q6 = 81, 84
COS_GAMMA = 87  # cosine of the fixed angle between the joint-5 and joint-6 axes
# the shoulder: Rot(k1, q1) Rot(k2, q2) Rot(k3, q3) = R(X0)ᵀ R3 Cᵀ, C = R(X1) R(X2)
X0 = 88  # R(X0), 3x3
A3 = 97  # the joint-3 axis in frame 3
M3C = 100  # Cᵀ M3: a unit vector perpendicular to a3 in frame 3
K1, K2, K3 = 103, 106, 109  # the shoulder axes at zero (placement frame of joint 1)
M3 = 112  # a unit vector perpendicular to k3 (same frame)
K1XK2 = 115  # k1 × k2
K12, K23 = 118, 119  # k1·k2, k2·k3
# 1.0 when k1 ⊥ k2 and k3 = ±k1 (to TWIN_TOL): the second shoulder solution is the
# first turned, (q1 + π, −q2, q3 + π) (module docstring of :mod:`.analytic`)
TWIN = 120
LO, HI = 121, 128  # joint limits, rad (7 each)
N_ARM = 135

# Slots of the packed constants of an S-R-S arm (:class:`redres.ik.srs.SRSArm`, whose
# docstring derives them) for ``solve_arm_angle``: the same length, the limits in the
# same slots ``LO``, ``HI``.
SRS_RF, SRS_PF = 0, 9  # the frame's placement in frame 7: rotation (3x3), origin (m)
SRS_W7 = 12  # the wrist point in frame 7, m
SRS_S = 15  # the shoulder point, world, m
SRS_K, SRS_P, SRS_INV_H, SRS_STRAIGHT = 18, 19, 20, 21  # elbow law; the stretched q4, rad
SRS_RL3, SRS_PL3 = 22, 31  # joint 4's placement in frame 3: rotation, origin (m)
SRS_A4 = 34  # the elbow axis
SRS_W4, SRS_S3 = 37, 40  # the wrist point in frame 4, the shoulder point in frame 3, m
SRS_ELBOW_POINT = 43  # the elbow point, m, in frame 4 (SRS_ELBOW_FRAME 1.0) or frame 3
SRS_ELBOW_FRAME = 46
SRS_REFERENCE = 47  # the arm angle's reference direction (unit)
SRS_LS, SRS_RS, SRS_SIGMA_S = 50, 59, 68  # the shoulder's Euler basis (L, Rʳ, σ)
SRS_LW, SRS_RW, SRS_SIGMA_W = 69, 78, 87  # the wrist's
#: The elbow reaches to this (|x| ≤ 1 + it), and the arm angle is defined above these
#: (the elbow's offset from S → W, m; the lever of the reference, per m² of |W − S|²):
#: the tolerances of :meth:`redres.ik.srs.SRSPoses.build`.
SRS_REACH_TOL, SRS_OFFSET_TOL, SRS_LEVER_TOL = 1e-12, 1e-9, 1e-9

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
#: The shoulder's second solution is the first one turned (``TWIN``) when ``|k1·k2|``
#: and ``|k1 × k3|`` are below this (their rounding only: the turned solution is exact
#: to about this, rad).
TWIN_TOL = 1e-14
