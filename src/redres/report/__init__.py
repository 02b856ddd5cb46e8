"""Reports of control runs: plots per robot, a comparison table and an animated 3D view,
in one self-contained HTML page (needs the ``report`` extra: matplotlib and plotly).

>>> from redres.report import write_report
>>> write_report("out", [(robot, log) for log in logs], title="Panda circle")  # doctest: +SKIP
"""

from .view3d import ArmAnimation, animation_figure, arm_animation, arm_frames, arm_points
from .writer import write_report

__all__ = [
    "ArmAnimation",
    "animation_figure",
    "arm_animation",
    "arm_frames",
    "arm_points",
    "write_report",
]
