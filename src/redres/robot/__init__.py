"""Robot models: kinematics and dynamics of one serial chain, on Pinocchio."""

from .dh import DHLink
from .robot import Reference, Robot

__all__ = ["DHLink", "Reference", "Robot"]
