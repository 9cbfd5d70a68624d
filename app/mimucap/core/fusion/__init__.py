"""Orientation fusion: gyro propagation, error-state EKF, offline smoother, BROAD metric.

Frames and order: ``q_world_from_sensor``, scalar-first Hamilton quaternions, world = ENU
(magnetic north along +y unless a declination is set). Modules, one concept each:

* :mod:`.algorithms` — the algorithm names of the command line (no numba);
* :mod:`.params` — :class:`FusionParams` (frozen settings, units in the names) and
  :data:`DEFAULT_FUSION_PARAMS`, the one parameter set for every sensor and recording;
* :mod:`.propagation` — RK4, coning-corrected third-order Taylor and exact gyro steps;
* :mod:`.state` — the filter state of S sensors and the per-sample diagnostic flags;
* :mod:`.disturbance` — rest detection, accelerometer weighting, magnetic rejection;
* :mod:`.kernels` — the compiled (numba) loops: error-state EKF and RTS backward pass;
* :mod:`.aot` — the module compiled ahead of time at installation (:mod:`.aot_build`): its
  name, its check against the current sources, its loading;
* :mod:`.kernel_selection` — which compiled kernels a process runs: that module when it is
  current, else numba's JIT (:mod:`.jit`, :mod:`.warmup`);
* :mod:`.ekf` — :class:`OrientationEKF` (online: ``update`` / ``update_batch``; several
  one-sensor filters in one call: :func:`update_together`) and :func:`fuse`;
* :mod:`.offline` — :func:`fuse_offline`, forward EKF plus RTS smoother;
* :mod:`.evaluation` — the BROAD error metric (total / heading / inclination RMSE).
"""

from __future__ import annotations

import importlib

#: Public name -> submodule defining it. Loaded on first use (PEP 562), so that importing
#: ``mimucap.core.fusion.algorithms`` (the command line's ``--help``) does not load numba.
_EXPORTS = {
    "ALGORITHMS": "algorithms", "FusionResult": "ekf", "OrientationEKF": "ekf", "fuse": "ekf",
    "update_together": "ekf", "fuse_offline": "offline", "DEFAULT_FUSION_PARAMS": "params",
    "FusionParams": "params", "FLAG_NAMES": "state", "FusionState": "state", "decode_flags": "state",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
