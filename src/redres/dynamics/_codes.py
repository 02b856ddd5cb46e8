"""The layout of the compiled operational-space step's output (internal), shared by
:func:`redres.dynamics._kernels.osc_step` and its caller (:mod:`redres.dynamics.osc`)
without importing numba; covered by the kernels' cache stamp (a ``_codes.py`` file).

For ``n`` joints: ``τ``, its task part, its null part, ``τ₀`` (``n`` each), then from
``4 n`` on the task error (6), the frame's pose and the target pose (16 each, row-major),
and the inverse's rank, σ_min, σ_max and damping (4).
"""

OUT_ERROR, OUT_POSE, OUT_TARGET, OUT_STATS, OUT_EXTRA = 0, 6, 22, 38, 42
