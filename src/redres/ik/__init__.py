"""Position inverse kinematics: :func:`ik` (CLIK with restarts, compiled on serial chains)
and the closed form of S-R-S arms with the arm angle (:mod:`.srs`, :mod:`.arcs`).

- :mod:`.solve`: :func:`ik`, the entry point; :mod:`.options`: :class:`IKResult` and the
  solver's checked options; :mod:`.reference`: the same iteration on Pinocchio;
  :mod:`._kernels`: the compiled iteration.
- :mod:`.solutions`: ``rr.ik_all`` (every solution at one value of the redundancy
  parameter, ``q7`` or the arm angle; one pose at an arm angle by the compiled form of
  :mod:`.srs`) and ``rr.self_motion`` (per branch, the parameter intervals within the
  joint limits); :mod:`.analytic`: the compiled closed form at ``q7``
  of arms with a spherical shoulder whose axes 5 and 6 meet (Panda, FR3, iiwa14, srs7);
- :mod:`.srs`: every configuration of a spherical-shoulder, spherical-wrist arm at a pose
  and arm angle (Shimizu et al., IEEE T-RO 24(5), 2008); :mod:`.arcs`: sets of arm angles
  as arcs of the circle.
"""

from .options import IKResult
from .solve import ik

__all__ = ["IKResult", "ik"]
