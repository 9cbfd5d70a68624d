"""MimuCap: human motion capture with magnetic-inertial measurement units.

Layers (imports point downwards only): ``gui`` → ``session`` → (``acquisition`` | ``io``) → ``core``.
See ``docs/`` and ``docs/conventions.md`` for frames, units and quaternion order
(Hamilton, scalar first ``[w, x, y, z]``).
"""

__version__ = "0.1.0"

__all__ = ["__version__"]
