"""Screenshots of the Library workspace and of a comparison (called by ``make_screenshots.py``).

A library is made in a scratch folder from simulated squats and walks (three subjects, one of
them seen before and six weeks after a knee operation, squatting less deep before), plus a
damaged file; the main window's Library workspace shows it, then the comparison of that
subject's two squat trials between their markers.
"""

from __future__ import annotations

from pathlib import Path

from PyQt5 import QtWidgets
from screenshots_common import known_mounting_calibration
from screenshots_common import wait as _wait

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


def make_library(folder: Path) -> None:
    """Simulated squats and walks as library sessions in ``folder`` (and one damaged file)."""
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.suit import simulate_session
    from mimucap.io.library import library_fields
    from mimucap.io.session import Marker, make_subject, session_from_simulation, write_session

    for name, subject, height, started, condition, tags, trial, scenario, parameters, seed in SESSIONS:
        # Error-free sensors worn along their segments, with that mounting as their body
        # calibration (comparisons need one).
        config = SimulationConfig(scenario=scenario, duration_s=8.0, seed=seed, height_m=height,
                                  scenario_params=parameters, errors="ideal", random_mounting=False)
        notes = "left knee arthroplasty" if subject == "P042" else ""
        result = simulate_session(config)
        session = session_from_simulation(result, make_subject(subject, height, "right", notes), include_truth=False)
        session.calibrations["body"] = known_mounting_calibration(result)
        session.metadata["recording"] = {"started_utc": started}
        session.metadata["library"] = library_fields(condition, tags, trial)
        session.markers = [Marker(0.5, f"{scenario} start"), Marker(7.5, f"{scenario} end")]
        write_session(folder / name, session)
    damaged = (folder / "P023_2026-05-18_trial01.h5").read_bytes()
    (folder / "P023_2026-05-25_trial01.h5").write_bytes(damaged[: len(damaged) // 3])


def write_library_screenshots(app: QtWidgets.QApplication, window, home: Path, out_dir: Path) -> list[Path]:
    """The Library workspace of main window ``window`` on a library made in ``home`` (the
    scratch home folder: the library reads ``~/MimuCap Library``), and a comparison."""
    from mimucap.gui.capture import save_window_png

    folder = home / "MimuCap Library"
    folder.mkdir()
    make_library(folder)
    window.library_folder = lambda: folder
    window.show_workspace("library")
    view = window.library_view
    view.wait_for_scan()
    view.select_subject(None)
    view.select_paths({"P042_2026-05-04_trial01.h5", "P042_2026-06-15_trial01.h5"})
    app.processEvents()
    written = [window.save_screenshot(out_dir / "library.png")]
    compare = view.compare_selected()
    _wait(app, lambda: bool(compare.tables) or compare.error is not None, 120, "the comparison")
    for picker in compare.pickers:
        picker.set_bounds(0, 1)
    rows = [row[0] for row in compare.tables[0].rows]
    table = compare.table_widgets[0]
    hip = next(k for k, row in enumerate(rows) if row in ("hip_r_flexion", "Right hip flexion"))
    table.scrollToItem(table.item(hip, 0), QtWidgets.QAbstractItemView.PositionAtTop)
    app.processEvents()
    written.append(save_window_png(compare, out_dir / "library-compare.png"))
    compare.close()
    window.show_workspace("capture")
    return written
