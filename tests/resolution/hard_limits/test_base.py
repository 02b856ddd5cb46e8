"""What the hard-limit schemes share (hard_limits.base): diagnostics from redres.linalg's
one rank rule on the schemes' own copy of J, linalg's status codes for bad input, checked
constructor keywords."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import redres as rr
from redres.errors import NonFiniteError, UnknownParameterError
from redres.linalg import _codes
from redres.objectives import Objective
from redres.resolution import QPScheme, SNSScheme
from redres.resolution.hard_limits._compiled import kernels
from redres.resolution.hard_limits.base import Workspace

DT = 1e-3
SCHEMES = (SNSScheme, QPScheme)


def conditioned(rng: np.random.Generator, ratio: float) -> np.ndarray:
    """A 6 x 7 J with singular values from 1 down to ``ratio``."""
    U = np.linalg.qr(rng.normal(size=(6, 6)))[0]
    V = np.linalg.qr(rng.normal(size=(7, 7)))[0]
    return np.ascontiguousarray(U @ np.diag(np.geomspace(1.0, ratio, 6)) @ V[:6])


@pytest.mark.parametrize("ratio", [1e-8, 1e-12])
def test_rank_is_linalg_rank(rng: np.random.Generator, ratio: float) -> None:
    """σ_min/σ_max = 1e-8: full rank for SNS, QP and rr.linalg.pinv alike (the old 1e-6
    cut of the schemes called it 5); 1e-12: rank 5 for all three (RCOND = 1e-10)."""
    robot = rr.models.panda()
    q = robot.neutral()
    J = conditioned(rng, ratio)
    _, reference = rr.linalg.pinv(J, return_info=True)
    assert reference.rank == (6 if ratio > 1e-10 else 5)
    for make in SCHEMES:
        info = make(dt=DT).step(robot, q, J, np.zeros(6)).info
        assert (info.rank, info.full_rank) == (reference.rank, reference.full_rank)
        assert info.sigma_min == pytest.approx(reference.sigma_min, rel=1e-6, abs=1e-15)
        assert info.sigma_max == pytest.approx(reference.sigma_max, rel=1e-12)


def test_info_reads_the_schemes_copy_of_the_jacobian(rng: np.random.Generator) -> None:
    """StepResult.info is computed on first read, from J as it was at the step: the caller
    (e.g. the controller, which reuses its arrays) may overwrite J meanwhile."""
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.3)
    for make in SCHEMES:
        J = robot.jacobian(q)
        expected = np.linalg.svd(J, compute_uv=False)
        result = make(dt=DT).step(robot, q, J, np.zeros(6))
        J[:] = 0.0
        assert result.info.sigma_max == pytest.approx(expected[0], rel=1e-12)
        assert result.info.sigma_min == pytest.approx(expected[-1], rel=1e-8)


class NaNObjective(Objective):
    def cost(self, robot: Any, q: np.ndarray) -> float:
        return 0.0

    def gradient(self, robot: Any, q: np.ndarray) -> np.ndarray:
        return np.full(robot.n, np.nan)


@pytest.mark.parametrize("make", SCHEMES)
def test_bad_input_names_the_argument(make: Any) -> None:
    robot = rr.models.panda()
    q = robot.neutral()
    J = robot.jacobian(q)
    xd = np.zeros(6)
    bad_q = q.copy()
    bad_q[2] = np.inf
    bad_J = J.copy()
    bad_J[1, 3] = np.nan
    cases = [(bad_q, J, xd, "q"), (q, bad_J, xd, "J"), (q, J, xd + np.nan, "xd")]
    for q_, J_, xd_, name in cases:
        with pytest.raises(NonFiniteError, match=f"^{name} contains NaN"):
            make(dt=DT).step(robot, q_, J_, xd_)
    with pytest.raises(NonFiniteError, match="secondary velocity"):
        make(dt=DT, objectives=[NaNObjective()]).step(robot, q, J, xd)


def test_kernels_return_linalg_status_codes() -> None:
    """One convention: the prologue's input checks are redres.linalg's positive codes."""
    robot = rr.models.panda()
    n, m = robot.n, 6
    ws = Workspace(rr.resolution.JointLimits.from_robot(robot), m)
    q, J, xd, qd0 = robot.neutral(), robot.jacobian(robot.neutral()), np.zeros(m), np.zeros(n)
    prologue = kernels().prologue

    def status(**bad: np.ndarray) -> int:
        args = {"q": q, "J": J, "xd": xd, "qd0": qd0, **bad}
        out, codes, Jc = ws.outputs()
        return int(prologue(args["q"], ws.zero, DT, ws.lim, args["J"], args["xd"],
                            args["qd0"], out, codes, Jc, ws.M)[0])  # fmt: skip

    assert status() == _codes.OK == 0
    assert status(q=q + np.nan) == _codes.Q_NONFINITE
    assert status(J=J + np.inf) == _codes.J_NONFINITE
    assert status(xd=xd + np.nan) == _codes.XD_NONFINITE
    assert status(qd0=qd0 + np.nan) == _codes.GRAD_NONFINITE


def test_constructors_check_their_keywords() -> None:
    with pytest.raises(UnknownParameterError, match="did you mean 'k_null'"):
        SNSScheme(dt=DT, k_nul=1.0)
    with pytest.raises(UnknownParameterError, match="'level_gain'"):
        QPScheme(dt=DT, level_gain=5.0)
    with pytest.raises(UnknownParameterError, match="k_null"):
        SNSScheme(dt=DT, gain=1.0)  # SNS has no levels: its only gain is k_null
    assert QPScheme(dt=DT, gain=5.0, k_null=2.0).gain == 5.0
