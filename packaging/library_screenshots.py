"""Screenshots of the library window and of a comparison (called by ``make_screenshots.py``).

A library is made in a scratch folder from simulated squats and walks (three subjects, one of
them seen before and six weeks after a knee operation, squatting less deep before), plus a
damaged file; the library window shows it, then the comparison of that subject's two squat
trials between their markers.

Usage alone: ``python packaging/library_screenshots.py OUT_DIR`` (under a display).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from PyQt5 import QtCore, QtWidgets

#: (file, subject, height m, started UTC, condition, tags, trial, scenario, its parameters, seed)
SESSIONS = (
    ("P042_2026-05-04_trial01.h5", "P042", 1.68, "2026-05-04T09:12:00+00:00", "pre-op", ["knee", "squat"],
     "trial01", "squat", {"depth": 0.45}, 1),
    ("P042_2026-05-04_trial02.h5", "P042", 1.68, "2026-05-04T09:20:00+00:00", "pre-op", ["knee", "gait"], "trial02",
     "walk", {"speed_mps": 0.8}, 2),
    ("P042_2026-06-15_trial01.h5", "P042", 1.68, "2026-06-15T10:02:00+00:00", "6 weeks", ["knee", "squat"],
     "trial01", "squat", {"depth": 0.75}, 3),
    ("P042_2026-06-15_trial02.h5", "P042", 1.68, "2026-06-15T10:09:00+00:00", "6 weeks", ["knee", "gait"],
     "trial02", "walk", {"speed_mps": 1.1}, 4),
    ("P017_2026-05-11_trial01.h5", "P017", 1.81, "2026-05-11T14:40:00+00:00", "baseline", ["hip", "gait"], "trial01",
     "walk", {"speed_mps": 1.3}, 5),
    ("P023_2026-05-18_trial01.h5", "P023", 1.74, "2026-05-18T08:05:00+00:00", "pre-op", ["gait"], "trial01", "walk",
     {"speed_mps": 1.0}, 6),
)


def _wait(app: QtWidgets.QApplication, condition, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise RuntimeError(f"timed out waiting for {what}")
        app.processEvents(QtCore.QEventLoop.AllEvents, 20)


def make_library(folder: Path) -> None:
    """Simulated squats and walks as library sessions in ``folder`` (and one damaged file)."""
    import numpy as np

    from mimucap.core import skeleton
    from mimucap.core.bodycal import BodyCalibration, CalibrationQuality
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.suit import simulate_session
    from mimucap.io.library import library_fields
    from mimucap.io.session import Marker, make_subject, session_from_simulation, write_session

    for name, subject, height, started, condition, tags, trial, scenario, parameters, seed in SESSIONS:
        # Error-free sensors worn along their segments, with that mounting as their body
        # calibration (as the N-pose/T-pose procedure would find it; comparisons need one).
        config = SimulationConfig(scenario=scenario, duration_s=8.0, seed=seed, height_m=height,
                                  scenario_params=parameters, errors="ideal", random_mounting=False)
        notes = "left knee arthroplasty" if subject == "P042" else ""
        result = simulate_session(config)
        session = session_from_simulation(result, make_subject(subject, height, "right", notes), include_truth=False)
        session.calibrations["body"] = BodyCalibration(
            q_world_from_body=skeleton.q_world_from_body_facing(0.0), up_world=np.array([0.0, 0.0, 1.0]),
            sensors={m.segment: sid for sid, m in result.mounting.items()},
            q_segment_from_sensor={m.segment: m.q_segment_from_sensor for m in result.mounting.values()},
            quality=CalibrationQuality("known mounting", ())).to_dict()
        session.metadata["recording"] = {"started_utc": started}
        session.metadata["library"] = library_fields(condition, tags, trial)
        session.markers = [Marker(0.5, f"{scenario} start"), Marker(7.5, f"{scenario} end")]
        write_session(folder / name, session)
    damaged = (folder / "P023_2026-05-18_trial01.h5").read_bytes()
    (folder / "P023_2026-05-25_trial01.h5").write_bytes(damaged[: len(damaged) // 3])


def write_library_screenshots(out_dir: Path) -> list[Path]:
    from mimucap.gui.capture import save_window_png
    from mimucap.gui.library_window import LibraryWindow

    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(["mimucap-screenshots"])
    written = []
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch) / "MimuCap Library"
        folder.mkdir()
        make_library(folder)
        window = LibraryWindow(folder, open_review=lambda path: None, new_session=lambda *subject: None)
        window.resize(1360, 560)
        window.show()
        window.wait_for_scan()
        window.select_subject(None)
        window.select_paths({"P042_2026-05-04_trial01.h5", "P042_2026-06-15_trial01.h5"})
        app.processEvents()
        written.append(save_window_png(window, out_dir / "library.png"))
        compare = window.compare_selected()
        compare.resize(1200, 860)
        _wait(app, lambda: bool(compare.tables) or compare.error is not None, 120, "the comparison")
        for picker in compare.pickers:
            picker.set_bounds(0, 1)
        rows = [row[0] for row in compare.tables[0].rows]
        table = compare.table_widgets[0]
        table.scrollToItem(table.item(rows.index("hip_r_flexion"), 0), QtWidgets.QAbstractItemView.PositionAtTop)
        app.processEvents()
        written.append(save_window_png(compare, out_dir / "library-compare.png"))
        compare.close()
        window.close()
    return written


if __name__ == "__main__":
    target = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/screenshots")
    for path in write_library_screenshots(target):
        print(path)
