"""The hard-limit schemes' kernel group (internal): the step (:mod:`._kernels`), the linear
program (:mod:`._lp_kernels`), the QP's own kernels (:mod:`._qp_kernels`) and its dense QP
solvers (:mod:`._dense_qp_kernels`)."""

from __future__ import annotations

from types import ModuleType

from ... import _compile

#: Cold: a first SNS step 16-18 s (with the linear program); the QP's own kernels 4 s more;
#: the dense QP solvers 6 s more.
KERNELS = _compile.KernelGroup(
    "hard limits",
    ("redres.resolution.hard_limits._kernels", "redres.resolution.hard_limits._lp_kernels",
     "redres.resolution.hard_limits._qp_kernels",
     "redres.resolution.hard_limits._dense_qp_kernels"),
    cold_seconds=17.0,
    others={"redres.resolution.hard_limits._qp_kernels": 4.0,
            "redres.resolution.hard_limits._dense_qp_kernels": 6.0},
)  # fmt: skip


def kernels(name: str = "_kernels", *, plain: bool = False) -> ModuleType:
    """Kernel module ``name`` of the group (``_kernels``, ``_lp_kernels``, ``_qp_kernels``,
    ``_dense_qp_kernels``):
    compiled, or its plain-Python twin while it compiles behind; ``plain``: the twin in
    any case (a scheme whose other module is still compiling).

    Raises:
        MissingDependencyError: numba cannot be imported (the hard-limit schemes have no
            NumPy path; ``REDRES_DISABLE_JIT=1`` runs their kernels as plain Python).
    """
    return KERNELS.required("the hard-limit schemes", name, plain=plain)


def pending(*names: str) -> tuple[str, ...]:
    """Those of the kernel modules ``names`` that are still compiling behind: a scheme
    that prepared its entry points on their plain twins prepares again once none is."""
    if not _compile.enabled():
        return ()
    return tuple(n for n in names if not _compile.is_compiled(kernels(n)))
