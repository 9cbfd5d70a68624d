"""``mimucap import``: a recording from another system as a MimuCap session file.

``mimucap import FILE.{mvnx,sto,xdf} --out SESSION.h5``

* Xsens MVNX (versions 3 and 4): the sensors' orientations and accelerations, the body
  calibration Xsens applied, the subject, and Xsens's own joint angles and segment data kept
  beside them (:mod:`mimucap.io.mvnx`).
* OpenSense orientation tables (``.sto``, ``DataType=Quaternion``): one sensor per column,
  assigned to our segment when the column is named ``<body>_imu`` after an OpenSim body
  (:data:`mimucap.io.opensense.OPENSIM_BODIES`); no body calibration (calibrate it with
  ``mimucap bodycal`` or in the review).
* XDF files (LabRecorder) with MimuCap's raw-sample streams (``MimuCap raw <sensor>``, streamed by
  ``mimucap stream --lsl`` or the window): every sensor's accelerometer, gyroscope and raw
  magnetometer at its sample times, its segment and device, and the file's marker streams as
  markers; session time 0 is the first sample (:mod:`mimucap.io.xdf`; needs ``pyxdf``:
  ``pip install 'mimucap[lsl]'``).

The session opens in the review (File → Open) and exports (``mimucap export``) like a recording
of ours.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mimucap.cli import check_output_path, refuse_to_overwrite_input


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "import",
        help="an Xsens MVNX file, an OpenSense .sto table or an XDF file as a MimuCap session",
        description=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("input", metavar="FILE", help="an .mvnx file, an OpenSense .sto table or an .xdf file")
    parser.add_argument("--out", required=True, metavar="SESSION.h5", help="session file to write")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if Path(args.out).suffix.lower() not in (".h5", ".hdf5"):
        raise ValueError(f"{args.out}: a session is an HDF5 file: name it .h5")
    check_output_path(args.out)
    refuse_to_overwrite_input(args.out, args.input)
    if Path(args.out).exists():  # it may be a recording: never replaced by an import
        raise OSError(f"{args.out} exists: choose another --out (an import never replaces a session file)")
    from mimucap.io.recording_import import import_recording

    from mimucap.io.session import session_duration_s

    session = import_recording(args.input, args.out)
    assigned = sorted({s.segment for s in session.sensors.values() if s.segment})
    duration = session_duration_s(session)
    print(f"wrote {args.out}: {len(session.sensors)} sensors ({len(assigned)} on segments: {', '.join(assigned)}), "
          f"{duration:.2f} s, {'with' if 'body' in session.calibrations else 'without'} body calibration")
    return 0
