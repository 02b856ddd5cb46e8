"""Fixtures of the dynamics tests: the two redundant arms, built once."""

from __future__ import annotations

import pytest

import redres as rr


@pytest.fixture(scope="session")
def panda() -> rr.Robot:
    return rr.models.panda()


@pytest.fixture(scope="session")
def iiwa() -> rr.Robot:
    return rr.models.iiwa14()


@pytest.fixture(scope="session", params=["panda", "iiwa14"])
def arm(request: pytest.FixtureRequest) -> rr.Robot:
    return rr.models.load(request.param)
