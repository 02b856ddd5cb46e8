"""Link capsules stay on their link: both end points follow the frames they were read
from, at every configuration (a capsule on the wrong link would drift)."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr

ENDS = {
    "panda": [
        ("base", "shoulder"),
        ("shoulder", "elbow"),
        ("elbow", "wrist"),
        ("wrist", "link7"),
        ("link7", "tcp"),
    ],
    "iiwa14": [
        ("link0", "shoulder"),
        ("shoulder", "elbow"),
        ("elbow", "wrist"),
        ("wrist", "flange"),
    ],
    "srs7": [("base", "shoulder"), ("shoulder", "elbow"), ("elbow", "wrist"), ("wrist", "tool")],
}


@pytest.mark.parametrize("name", sorted(ENDS))
def test_capsule_end_points_are_rigid(name: str, rng: np.random.Generator) -> None:
    robot = rr.models.load(name)
    assert len(robot.capsules) == len(ENDS[name])
    for _ in range(10):
        q = robot.random_configuration(rng)
        for cap, (start, end) in zip(robot.capsules, ENDS[name]):
            T = robot.fk(q, cap.frame)
            a = T[:3, :3] @ cap.a + T[:3, 3]
            b = T[:3, :3] @ cap.b + T[:3, 3]
            assert np.allclose(a, robot.fk(q, start)[:3, 3], atol=1e-12), cap.name
            assert np.allclose(b, robot.fk(q, end)[:3, 3], atol=1e-12), cap.name


def test_capsule_chain_is_one_capsule_between_per_segment() -> None:
    """The chain's capsule i is ``capsule_between(links[i], points[i], points[i+1])``, and
    mismatched lengths are refused by name."""
    from redres.errors import ShapeError
    from redres.robot import capsule_between, capsule_chain

    robot = rr.models.panda()
    points, links = ("base", "shoulder", "elbow", "tcp"), ("link1", "link3", "link7")
    chain = capsule_chain(robot, points, links, (0.1, 0.2, 0.3), names=("a", "b", "c"))
    for i, capsule in enumerate(chain):
        one = capsule_between(robot, links[i], points[i], points[i + 1], (0.1, 0.2, 0.3)[i])
        assert (capsule.frame, capsule.radius, capsule.name) == (links[i], one.radius, "abc"[i])
        np.testing.assert_array_equal(capsule.a, one.a)
        np.testing.assert_array_equal(capsule.b, one.b)
    assert capsule_chain(robot, points, links, (0.1, 0.2, 0.3))[1].name == "shoulder-elbow"
    with pytest.raises(ShapeError, match="4 points, 2 links"):
        capsule_chain(robot, points, links[:2], (0.1, 0.2))
    with pytest.raises(ShapeError, match="2 names"):
        capsule_chain(robot, points, links, (0.1, 0.2, 0.3), names=("a", "b"))


@pytest.mark.parametrize("radius", [-0.01, float("nan"), "thick"])
def test_a_capsule_radius_that_is_not_a_length_is_refused_by_name(radius: object) -> None:
    from redres.errors import RedresError
    from redres.robot import capsule_between, capsule_chain

    robot = rr.models.panda()
    with pytest.raises(RedresError, match="radius"):
        capsule_between(robot, "link1", "base", "shoulder", radius)  # type: ignore[arg-type]
    with pytest.raises(RedresError, match="radius"):
        capsule_chain(robot, ("base", "shoulder"), ("link1",), (radius,))  # type: ignore[arg-type]
