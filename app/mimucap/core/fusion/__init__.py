"""Orientation fusion: gyro propagation, error-state EKF, offline smoother, BROAD metric.

Frames and order: ``q_world_from_sensor``, scalar-first Hamilton quaternions, world = ENU
(magnetic north along +y unless a declination is set). Modules, one concept each:

* :mod:`.params` — :class:`FusionParams` (frozen settings, units in the names) and
  :data:`DEFAULT_FUSION_PARAMS`, the one parameter set for every sensor and recording;
* :mod:`.propagation` — RK4, coning-corrected third-order Taylor and exact gyro steps;
* :mod:`.state` — the filter state of S sensors and the per-sample diagnostic flags;
* :mod:`.disturbance` — rest detection, accelerometer weighting, magnetic rejection;
* :mod:`.kernels` — the compiled (numba) error-state EKF loop;
* :mod:`.ekf` — :class:`OrientationEKF` (online: ``update`` / ``update_batch``; several
  one-sensor filters in one call: :func:`update_together`) and :func:`fuse`;
* :mod:`.offline` — :func:`fuse_offline`, forward EKF plus RTS smoother;
* :mod:`.evaluation` — the BROAD error metric (total / heading / inclination RMSE).
"""

from mimucap.core.fusion.ekf import ALGORITHMS, FusionResult, OrientationEKF, fuse, update_together
from mimucap.core.fusion.offline import fuse_offline
from mimucap.core.fusion.params import DEFAULT_FUSION_PARAMS, FusionParams
from mimucap.core.fusion.state import FLAG_NAMES, FusionState, decode_flags

__all__ = [
    "ALGORITHMS", "DEFAULT_FUSION_PARAMS", "FLAG_NAMES", "FusionParams", "FusionResult",
    "FusionState", "OrientationEKF", "decode_flags", "fuse", "fuse_offline", "update_together",
]
