"""What the magnetometer wizard's live views draw, computed from the samples and the fit.

:func:`magcal_display` thins the recording to at most ``max_points`` samples and derives
everything the 3D view and the ``|field|`` plot need, so the GUI only shows arrays:

* the raw samples (sensor frame, µT) with their time and a 0…1 colour fraction (early → late);
* ``|raw|`` and, once there is a fit, the corrected samples ``soft_iron · (raw − offset)``
  and ``|corrected|`` (µT);
* the ``(4, 4)`` matrix mapping the unit sphere onto the fitted ellipsoid, and the field
  radius (µT);
* where to look: the centre and size (µT) of the raw cloud (the ellipsoid when fitted).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mimucap.core.magcal.fit import EllipsoidFit


@dataclass(frozen=True)
class MagcalDisplay:
    """One update of the magnetometer views (``N`` samples shown, sensor frame, µT)."""

    raw_uT: NDArray[np.float64]               #: ``(N, 3)`` raw samples
    t_s: NDArray[np.float64]                  #: ``(N,)`` seconds since the first sample shown
    time_fraction: NDArray[np.float64]        #: ``(N,)`` 0 (first) … 1 (last), for colouring
    raw_norm_uT: NDArray[np.float64]          #: ``(N,)`` ``|raw|``
    centre_uT: NDArray[np.float64]            #: ``(3,)`` centre of the raw cloud (ellipsoid centre once fitted)
    extent_uT: float                          #: size of the raw cloud (largest ellipsoid radius once fitted)
    fit: EllipsoidFit | None = None
    corrected_uT: NDArray[np.float64] | None = None       #: ``(N, 3)``
    corrected_norm_uT: NDArray[np.float64] | None = None  #: ``(N,)``
    ellipsoid_matrix: NDArray[np.float64] | None = None   #: ``(4, 4)`` unit sphere → fitted ellipsoid
    field_uT: float | None = None                         #: the fitted field radius

    @property
    def count(self) -> int:
        return int(self.raw_uT.shape[0])


def magcal_display(mag_raw_uT: ArrayLike, t_s: ArrayLike, fit: EllipsoidFit | None,
                   max_points: int = 4000) -> MagcalDisplay:
    """The views' data for samples ``mag_raw_uT`` ``(N, 3)`` µT at ``t_s`` ``(N,)`` s and
    ``fit`` (None before the first fit); evenly thinned to ``max_points`` samples."""
    mag = np.asarray(mag_raw_uT, dtype=np.float64).reshape(-1, 3)
    t = np.asarray(t_s, dtype=np.float64).reshape(-1)
    if mag.shape[0] != t.shape[0]:
        raise ValueError(f"{mag.shape[0]} magnetometer samples but {t.shape[0]} times")
    if max_points < 2:
        raise ValueError(f"max_points must be at least 2, got {max_points}")
    if mag.shape[0] > max_points:
        pick = np.linspace(0, mag.shape[0] - 1, max_points).astype(int)
        mag, t = mag[pick], t[pick]
    n = mag.shape[0]
    t_rel = t - t[0] if n else t
    span = float(t_rel[-1]) if n > 1 else 0.0
    fraction = t_rel / span if span > 0 else np.zeros(n)
    if fit is None:
        centre = mag.mean(axis=0) if n else np.zeros(3)
        extent = float(np.max(np.linalg.norm(mag - centre, axis=1))) if n else 0.0
        return MagcalDisplay(raw_uT=mag, t_s=t_rel, time_fraction=fraction,
                             raw_norm_uT=np.linalg.norm(mag, axis=1), centre_uT=centre, extent_uT=extent)
    ellipsoid = fit.ellipsoid
    matrix = np.eye(4)
    matrix[:3, :3] = ellipsoid.axes @ np.diag(ellipsoid.radii)
    matrix[:3, 3] = ellipsoid.centre
    corrected = fit.apply(mag) if n else np.zeros((0, 3))
    return MagcalDisplay(
        raw_uT=mag, t_s=t_rel, time_fraction=fraction, raw_norm_uT=np.linalg.norm(mag, axis=1),
        centre_uT=np.asarray(ellipsoid.centre, dtype=float), extent_uT=float(np.max(ellipsoid.radii)),
        fit=fit, corrected_uT=corrected, corrected_norm_uT=np.linalg.norm(corrected, axis=1),
        ellipsoid_matrix=matrix, field_uT=float(fit.field_uT))
