"""The kernels' status and outcome codes: one IntEnum per kernel family, whose plain-int
copies (what the kernels compile in) carry the same names and values."""

import pytest

from redres.ik import _layout
from redres.linalg import _codes
from redres.linalg._status import raise_status
from redres.resolution.hard_limits import _codes as hl_codes


@pytest.mark.parametrize(
    ("module", "enum"),
    [
        (_codes, _codes.Status),
        (hl_codes, hl_codes.BoundKind),
        (hl_codes, hl_codes.Outcome),
        (hl_codes, hl_codes.Simplex),
        (_layout, _layout.Status),
    ],
)
def test_every_plain_code_is_its_enum_member(module, enum):
    for member in enum:
        value = getattr(module, member.name)
        assert type(value) is int and value == member.value


def test_names_follow_the_enums():
    assert hl_codes.BOUND_KINDS == ("none", "position", "velocity", "acceleration")
    assert len(hl_codes.METHODS) == len(hl_codes.Outcome)


def test_an_unknown_status_is_named_in_the_error():
    with pytest.raises(RuntimeError, match=r"status 17 \(Q_SHAPE\)"):
        raise_status(_codes.Q_SHAPE, {})
    with pytest.raises(RuntimeError, match="status 13 .not a status"):
        raise_status(13, {})
