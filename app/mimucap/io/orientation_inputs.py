"""Which orientation input a path is, and the reader for it.

Kinds (named in :mod:`mimucap.io.input_names`, which the command line reads without loading
numpy): an Xsens export folder or file (:mod:`mimucap.io.xsens_text`), an OpenSim ``.sto``
table and a MimuCap orientation CSV (:mod:`mimucap.io.orientation_tables`), an APDM CSV
(:mod:`mimucap.io.apdm_csv`). MimuCap sessions and BROAD trials hold raw samples, not
orientations: they are recognised (:func:`orientation_input_kind`) and refused by
:func:`read_quaternion_table`, since their orientations come from the processing path
(:mod:`mimucap.core.pipeline`), never from a reader.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mimucap.io.apdm_csv import read_apdm_csv
from mimucap.io.input_names import (
    APDM_CSV, BROAD_TRIAL, MIMUCAP_SESSION, OPENSIM_STO, QUATERNION_CSV, SESSION_SUFFIXES, XSENS_FILE,
    XSENS_FOLDER,
)
from mimucap.io.orientation_tables import QuaternionTable, axis_vector, read_opensim_sto, read_quaternion_csv
from mimucap.io.xsens_text import merge_xsens_recordings, read_xsens_file, read_xsens_folder, read_xsens_mapping


def orientation_input_kind(path: str | Path) -> str:
    """Which kind of input ``path`` is (one of the kinds of :mod:`mimucap.io.input_names`), as
    :func:`read_quaternion_table` tells them apart: a folder is an Xsens export folder, then
    the suffix decides (``.sto``, ``.txt``, ``.h5``/``.hdf5``/``.mimucap``, ``.csv`` whose first
    line ``Format=`` marks APDM). An HDF5 file laid out as a BROAD trial is a BROAD trial.
    ``FileNotFoundError`` for a missing path, ``ValueError`` for an unknown suffix."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file or folder")
    if path.is_dir():
        return XSENS_FOLDER
    suffix = path.suffix.lower()
    if suffix == ".sto":
        return OPENSIM_STO
    if suffix in SESSION_SUFFIXES:
        from mimucap.io.broad_trials import is_broad_file

        return BROAD_TRIAL if is_broad_file(path) else MIMUCAP_SESSION
    if suffix == ".txt":
        return XSENS_FILE
    if suffix == ".csv":
        with path.open(encoding="utf-8") as handle:
            first = handle.readline()
        return APDM_CSV if first.startswith("Format=") else QUATERNION_CSV
    raise ValueError(
        f"{path}: unknown orientation file type {suffix!r} (use .csv, .sto, an Xsens .txt or "
        "folder, or a MimuCap session .h5)"
    )


#: Why an up axis cannot be chosen for some inputs.
_FIXED_UP = "Xsens exports and APDM files are z up"


def _refuse_up_axis(path: Path, up_axis: str | None) -> None:
    """``ValueError`` when an up axis other than +z is given for an input whose world is z up
    (it would otherwise be ignored without a word)."""
    if up_axis is not None and not np.allclose(axis_vector(up_axis), (0.0, 0.0, 1.0)):
        raise ValueError(f"{path}: up axis {up_axis} cannot apply: {_FIXED_UP}")


def read_quaternion_table(
    path: str | Path,
    up_axis: str | None = None,
    sensor_names: str | Path | None = None,
    trial_prefix: str | None = None,
    rate_hz: float | None = None,
) -> QuaternionTable:
    """Read any supported orientation file or folder (see the module docstring).

    ``up_axis`` overrides the up axis the format implies (only for CSV and ``.sto``: Xsens,
    APDM and sessions are always z up, and another up axis given for them is refused rather
    than ignored). ``sensor_names`` (an OpenSense mapping XML), ``trial_prefix`` and
    ``rate_hz`` (used when a header gives no rate; a positive number) apply to Xsens exports.
    """
    path = Path(path)
    kind = orientation_input_kind(path)
    if kind == XSENS_FOLDER:
        _refuse_up_axis(path, up_axis)
        return read_xsens_folder(path, sensor_names, trial_prefix, rate_hz)
    if kind == OPENSIM_STO:
        return read_opensim_sto(path, up_axis)
    if kind in (MIMUCAP_SESSION, BROAD_TRIAL):
        raise ValueError(f"{path}: {kind} hold raw samples, not orientations: their orientations come from "
                         "the processing path (mimucap bodycal, angles and fuse read them)")
    if kind == XSENS_FILE:
        _refuse_up_axis(path, up_axis)
        rec = read_xsens_file(path, rate_hz)
        name = rec.device_id
        if sensor_names is not None:
            name = read_xsens_mapping(sensor_names).names.get(rec.device_id, rec.device_id)
        return merge_xsens_recordings({name: rec}, source=str(path))
    if kind == APDM_CSV:
        _refuse_up_axis(path, up_axis)
        return read_apdm_csv(path)
    return read_quaternion_csv(path, up_axis)
