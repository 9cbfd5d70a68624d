"""Recordings of other systems as MimuCap sessions: one entry for the command line and the window.

:func:`session_from_file` reads an Xsens MVNX file (:func:`mimucap.io.mvnx.session_from_mvnx`) or
an OpenSense orientation table (:func:`mimucap.io.opensense.session_from_sto`) or MimuCap's raw
streams in a LabRecorder XDF file (:func:`mimucap.io.xdf.session_from_xdf`) by its suffix;
:func:`import_recording` writes the session file that the review and the exports then open.
"""

from __future__ import annotations

from pathlib import Path

#: Suffixes of the recordings that can be imported, and what they are.
IMPORT_SUFFIXES = {".mvnx": "Xsens MVNX", ".sto": "OpenSense orientation table",
                   ".xdf": "XDF (LabRecorder) with MimuCap's raw streams"}


def session_from_file(path: str | Path):
    """A :class:`~mimucap.io.session.Session` of an ``.mvnx``, OpenSense ``.sto`` or ``.xdf`` file."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".mvnx":
        from mimucap.io.mvnx import read_mvnx, session_from_mvnx

        return session_from_mvnx(read_mvnx(path))
    if suffix == ".sto":
        from mimucap.io.opensense import session_from_sto

        return session_from_sto(path)
    if suffix == ".xdf":
        from mimucap.io.xdf import session_from_xdf

        return session_from_xdf(path)
    raise ValueError(f"{path}: import reads Xsens .mvnx files, OpenSense .sto tables and XDF files, "
                     f"not {suffix or 'no suffix'!r}")


def import_recording(path: str | Path, out: str | Path):
    """Read ``path`` (see :func:`session_from_file`) and write it as the session file ``out``;
    returns the session."""
    from mimucap.io.session import write_session

    if Path(out).suffix.lower() not in (".h5", ".hdf5"):
        raise ValueError(f"{out}: a session is an HDF5 file: name it .h5")
    session = session_from_file(path)
    write_session(out, session)
    return session
