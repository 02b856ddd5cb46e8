"""The sweep kinds, by the name a spec gives (``kind = "capability"``), and their modules:
each kind's parameters, its typed view of a finished sweep and its exports."""

from __future__ import annotations

from ..kind import Kind
from . import capability, ikdata, placement, plans, redundancy, reuleaux, schemes
from .capability import CAPABILITY
from .ikdata import IK_DATASET
from .placement import BASE_PLACEMENT
from .plans import PATH_PLANS
from .redundancy import REDUNDANCY_MAP
from .schemes import SCHEME_STATISTICS

__all__ = [
    "KINDS",
    "capability",
    "ikdata",
    "placement",
    "plans",
    "redundancy",
    "reuleaux",
    "schemes",
]

#: Every sweep kind by name, in the order ``redres sweep --list`` shows them.
KINDS: dict[str, Kind] = {
    kind.name: kind
    for kind in (
        CAPABILITY,
        REDUNDANCY_MAP,
        IK_DATASET,
        BASE_PLACEMENT,
        SCHEME_STATISTICS,
        PATH_PLANS,
    )
}
