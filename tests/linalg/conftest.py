"""Fixtures for the redres.linalg tests."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from redres.linalg import _backend


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator, so that each test sees the same numbers on every run."""
    return np.random.default_rng(20240601)


@pytest.fixture(params=["compiled", "numpy"])
def backend(request: pytest.FixtureRequest) -> Iterator[str]:
    """Run a test once with the compiled kernels and once on the NumPy reference path."""
    with _backend.jit_enabled(request.param == "compiled"):
        yield request.param
