"""The compiled IK's packed arrays and its tuning constants, read by the kernel
(:mod:`._kernels`), its caller (:mod:`.solve`) and the reference path (:mod:`.reference`).

Flat arrays cross the Python → kernel boundary only, with every slot named here:

- ``options`` (:data:`N_OPTIONS`): the solver settings, in the order of
  :data:`OPTION_NAMES`;
- ``io``: ``q`` (n), the best ``q`` found (n), then the ``state`` (:data:`N_STATE`) kept
  between calls for one target: slot ``2 n + BEST_SCORE`` and so on.

A kernel compiles these values in, so this module is covered by the cache stamp (its
name: ``_layout.py``).
"""

from __future__ import annotations

from enum import IntEnum


class Status(IntEnum):
    """How a call of the compiled solve ended (negative: it refused its input)."""

    CONVERGED = 0
    STALLED = 1  # the last attempt stalled
    BUDGET = 2  # it used its iterations


#: Status values as plain ints, for the kernel.
CONVERGED, STALLED, BUDGET = int(Status.CONVERGED), int(Status.STALLED), int(Status.BUDGET)

#: Slots of ``options``.
TOL_POSITION, TOL_ORIENTATION, MAX_STEP, K_LIMITS, MAX_DAMPING, THRESHOLD = range(6)
PREFERENCE_TOL, MAX_ITERATIONS, PATIENCE, N_OPTIONS = 6, 7, 8, 9
OPTION_NAMES = ("tol_position", "tol_orientation", "max_step", "k_limits", "max_damping",
                "threshold", "preference_tol", "max_iterations", "patience")  # fmt: skip

#: Slots of ``state``, after ``q`` and the best ``q`` in ``io``.
BEST_SCORE, BEST_POSITION, BEST_ORIENTATION, ERR_POSITION, ERR_ORIENTATION = range(5)
UNSETTLED, N_STATE = 5, 6

#: The iteration's constants, the same on both paths.
ERROR_SCALE = 0.1  # m or rad: damping and the joint-limit term fade out below this error
PREFERENCE_GAIN = 0.5  # fraction of the distance to the preference covered per iteration
PREFERENCE_STEP = 0.1  # rad: largest joint motion per iteration toward the preference
STICKY_ERROR = 1e-3  # m + rad: above this error in phase 2, clamped joints are released
# An attempt whose error has not fallen by FLAT_GAIN in FLAT_ITERATIONS iterations has
# stalled (stuck at a local minimum, often at limits).
FLAT_ITERATIONS, FLAT_GAIN = 3, 0.01
