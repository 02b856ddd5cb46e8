"""Robot models: kinematics and dynamics of one serial chain, on Pinocchio."""

from .capsules import Capsule, capsule_between
from .dh import DHLink
from .robot import Reference, Robot

__all__ = ["Capsule", "DHLink", "Reference", "Robot", "capsule_between"]
