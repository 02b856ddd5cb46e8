"""Short real runs shared by the report tests (built once per session)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import redres as rr
from redres.control import Circle, Hold, RunLog
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme
from redres.tasks import FrameTask

Runs = list[tuple[rr.Robot, RunLog]]


def make_runs() -> Runs:
    """Panda on a 2 cm circle (pinv; gradient projection logging the joint-limit cost),
    iiwa14 holding a pose 2 cm away (pinv): 150 and 120 steps."""
    panda = rr.models.panda()
    iiwa = rr.models.iiwa14()
    circle = Circle(panda.fk(panda.neutral()), 0.02, 0.15, turns=1.0)
    runs: Runs = []
    for scheme in (PseudoInverseScheme(), GradientProjectionScheme([JointLimitObjective()])):
        runs.append((panda, rr.run(panda, FrameTask(), circle, scheme, dt=1e-3)))
    target = iiwa.fk(iiwa.neutral())
    target[:3, 3] += [0.0, 0.02, -0.01]
    log = rr.run(iiwa, FrameTask(), Hold(target, 0.12), PseudoInverseScheme(), label="pinv hold")
    runs.append((iiwa, log))
    return runs


@pytest.fixture(scope="session")
def runs() -> Runs:
    return make_runs()


@pytest.fixture(scope="session")
def frameless_log(runs: Runs) -> RunLog:
    """A run as a task without a frame records it: zero positions and targets."""
    log = runs[0][1]
    zeros = np.zeros_like(log.position)
    return dataclasses.replace(log, position=zeros, target=zeros.copy(), label="frameless")
