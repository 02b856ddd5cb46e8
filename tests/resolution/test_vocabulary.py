"""One vocabulary for every scheme: ``inverse=`` or ``damping=``/``rcond=``, ``k_null`` for
null-space gains, misspelt keywords named, and one shape check in ``step``."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import redres as rr
from redres.errors import (
    InvalidParameterError,
    NonFiniteError,
    RedresError,
    ShapeError,
    UnknownParameterError,
)
from redres.linalg import AdaptiveDamping
from redres.objectives import JointLimitObjective
from redres.resolution import (
    AugmentedJacobianScheme,
    GradientProjectionScheme,
    Inverse,
    PriorityScheme,
    PseudoInverseScheme,
    QPScheme,
    Scheme,
    SNSScheme,
    WeightedLeastNormScheme,
)
from redres.tasks import PostureTask

#: Every scheme, built with defaults (and one objective where one is needed).
SCHEMES: dict[str, Callable[[], Scheme]] = {
    "pinv": PseudoInverseScheme,
    "gradient_projection": lambda: GradientProjectionScheme([JointLimitObjective()]),
    "wln": WeightedLeastNormScheme,
    "augmented": AugmentedJacobianScheme,
    "priority": lambda: PriorityScheme([PostureTask()]),
    "qp": lambda: QPScheme(dt=1e-3),
    "sns": lambda: SNSScheme(dt=1e-3),
}


def test_a_damping_keyword_damps_the_pseudo_inverse(rng: np.random.Generator) -> None:
    """``PseudoInverseScheme(damping=0.5)`` is ``Jᵀ(JJᵀ + 0.25 I)⁻¹ ẋ``, identifier dls."""
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.1)
    J, xd = robot.jacobian(q), rng.normal(size=6)
    scheme = PseudoInverseScheme(damping=0.5)
    assert scheme.name == "dls" and scheme.inverse == Inverse(0.5)
    qd = scheme.step(robot, q, J, xd).qd
    expected = J.T @ np.linalg.solve(J @ J.T + 0.25 * np.eye(6), xd)
    assert np.allclose(qd, expected, rtol=0, atol=1e-12)
    assert not np.allclose(qd, np.linalg.pinv(J) @ xd, atol=1e-3)  # really damped
    assert PseudoInverseScheme().name == "pinv"
    assert PseudoInverseScheme(rcond=1e-3).name == "pinv"
    assert PseudoInverseScheme(damping=AdaptiveDamping(0.1, 0.05)).name == "dls"


def test_every_scheme_exposes_its_inverse_and_null_space_gain() -> None:
    objectives = [JointLimitObjective()]
    assert GradientProjectionScheme(objectives, k_null=2.5).k_null == 2.5
    assert WeightedLeastNormScheme(k_null=0.5).k_null == 0.5
    for scheme in (
        PseudoInverseScheme(damping=0.1),
        GradientProjectionScheme(objectives, damping=0.1),
        WeightedLeastNormScheme(damping=0.1),
        AugmentedJacobianScheme(damping=0.1),
        PriorityScheme([PostureTask()], method="damped", damping=0.1),
    ):
        assert scheme.inverse == Inverse(0.1), type(scheme).__name__
    assert PseudoInverseScheme().k_null == 0.0
    assert SNSScheme(k_null=0.5).k_null == 0.5
    assert AugmentedJacobianScheme().inverse == Inverse(AdaptiveDamping(0.05, 0.02))
    assert PriorityScheme(method="robust").inverse.kind == "adaptive"


@pytest.mark.parametrize(
    "make",
    [
        lambda: PseudoInverseScheme(damping=0.1, rcond=1e-3),
        lambda: GradientProjectionScheme([JointLimitObjective()], damping=0.1, rcond=1e-3),
        lambda: WeightedLeastNormScheme(damping=AdaptiveDamping(0.1, 0.05), rcond=1e-3),
        lambda: AugmentedJacobianScheme(damping=0.1, rcond=1e-3),
        lambda: PriorityScheme([PostureTask()], method="damped", damping=0.1, rcond=1e-3),
        lambda: PriorityScheme([PostureTask()], damping=0.1),  # "exact" has no damping
        lambda: PriorityScheme([PostureTask()], inverse=Inverse(0.05)),
        lambda: PseudoInverseScheme(Inverse(0.1), damping=0.1),  # both ways at once
        lambda: PseudoInverseScheme(Inverse(), rcond=1e-3),
    ],
)
def test_a_damping_or_rcond_the_inverse_does_not_use_is_refused(
    make: Callable[[], Scheme],
) -> None:
    with pytest.raises(InvalidParameterError):
        make()


@pytest.mark.parametrize(
    ("make", "valid"),
    [
        (lambda: GradientProjectionScheme([JointLimitObjective()], dampnig=0.1), "damping"),
        (lambda: GradientProjectionScheme([JointLimitObjective()], gain=5.0), "k_null"),
        (lambda: WeightedLeastNormScheme(k_nul=1.0), "k_null"),
        (lambda: PseudoInverseScheme(rcnd=1e-3), "rcond"),
        (lambda: AugmentedJacobianScheme(max_damping=0.1), "damping"),
        (lambda: PriorityScheme(methd="robust"), "method"),
        (lambda: SNSScheme(dt=1e-3, gain=1.0), "k_null"),
        (lambda: QPScheme(dt=1e-3, k_nul=1.0), "k_null"),
    ],
)
def test_a_misspelt_keyword_names_the_valid_one(make: Callable[[], Scheme], valid: str) -> None:
    with pytest.raises(UnknownParameterError, match=valid) as caught:
        make()
    assert isinstance(caught.value, RedresError) and isinstance(caught.value, TypeError)


@pytest.mark.parametrize("kind", sorted(SCHEMES))
def test_a_wrong_width_jacobian_is_a_shape_error_from_every_scheme(kind: str) -> None:
    """A 6x3 Jacobian for the 7-joint Panda is refused by ``step`` before any solve."""
    robot = rr.models.panda()
    try:
        scheme = SCHEMES[kind]()
    except rr.errors.MissingDependencyError:
        pytest.skip("the qp extra is not installed")
    q = robot.neutral()
    with pytest.raises(ShapeError, match=r"J must have shape \(6, 7\)"):
        scheme.step(robot, q, np.ones((6, 3)), np.zeros(6))


@pytest.mark.parametrize("kind", sorted(SCHEMES))
@pytest.mark.parametrize(
    ("argument", "bad", "error"),
    [
        ("xd", np.nan, NonFiniteError),
        ("xd", np.inf, NonFiniteError),
        ("q", np.nan, NonFiniteError),
        ("J", -np.inf, NonFiniteError),
        ("q", 0.5j, InvalidParameterError),
        ("J", 1j, InvalidParameterError),
    ],
)
def test_every_scheme_refuses_non_finite_and_complex_input_by_name(
    kind: str, argument: str, bad: complex, error: type[Exception]
) -> None:
    """``step`` names the argument: no all-NaN joint velocity (the priority scheme gave
    one for a NaN ``xd`` or ``q``), no weights silently dropped (WLN with a NaN ``q``), no
    imaginary part silently discarded."""
    robot = rr.models.iiwa14() if kind == "augmented" else rr.models.panda()
    try:
        scheme = SCHEMES[kind]()
    except rr.errors.MissingDependencyError:
        pytest.skip("the qp extra is not installed")
    q = robot.neutral()
    J = robot.jacobian(q)
    inputs: dict[str, Any] = {"q": q, "J": J, "xd": np.full(6, 0.01)}
    value = inputs[argument].astype(complex) if isinstance(bad, complex) else inputs[argument]
    value = value.copy()
    value.flat[0] = bad
    inputs[argument] = value
    with pytest.raises(error, match=f"^{argument} "):
        scheme.step(robot, inputs["q"], inputs["J"], inputs["xd"])
