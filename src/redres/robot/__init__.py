"""Robot models: kinematics and dynamics of one serial chain, on Pinocchio."""

from ._frames import Reference
from .capsules import Capsule, capsule_between, capsule_chain
from .chain import ChainPoseError, NotSerialChainError, SerialChain
from .dh import DHLink
from .files import LoadOptions
from .robot import Robot

__all__ = [
    "Capsule",
    "ChainPoseError",
    "DHLink",
    "LoadOptions",
    "NotSerialChainError",
    "Reference",
    "Robot",
    "SerialChain",
    "capsule_between",
    "capsule_chain",
]
