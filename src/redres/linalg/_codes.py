"""Integer codes shared by the compiled kernels and their Python callers (internal).

Kept apart from :mod:`redres.linalg._kernels` so that callers can use them without
importing numba.
"""

from __future__ import annotations

# Status codes returned by the kernels (0 = success); each names one argument.
OK = 0
J_NONFINITE = 1
XD_NONFINITE = 2
GRAD_NONFINITE = 3
W_NONFINITE = 4
W_NOT_SPD = 5
W_ASYMMETRIC = 6
XD_SHAPE = 7
GRAD_SHAPE = 8
W_SHAPE = 9
J_EMPTY = 10
K_NONFINITE = 11
DAMPING_NONFINITE = 12
DAMPING_NEGATIVE = 13
RCOND_NONFINITE = 14
RCOND_NEGATIVE = 15

# Damping modes.
EXACT = 0
FIXED = 1
ADAPTIVE = 2
SELECTIVE = 3

# Weight modes.
NO_WEIGHTS = 0
DIAGONAL = 1
FULL = 2
