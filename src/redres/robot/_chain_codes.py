"""Joint kinds of the serial-chain kernels (values of ``SerialChain.arrays``' ``kinds``):
revolute about the joint frame's x, y, z axis or any unit axis, and prismatic along any
unit axis. A plain module, so that building a chain does not load the kernels; covered
by the kernels' cache stamp (a ``_*_codes.py`` file: :mod:`redres._compile._cache`)."""

REVOLUTE_X = 0
REVOLUTE_Y = 1
REVOLUTE_Z = 2
REVOLUTE = 3
PRISMATIC = 4
