"""Screenshots of Assess → Clinical Test, its report, the trend of a subject's visits and the
pairing offer (called by ``make_screenshots.py``).

``write_clinical_test_screenshots`` runs the guided Timed Up and Go in a main window whose
simulated suit has both calibrations (the subject, P001, does what the wizard asks): the choice
page, the run page during the countdown and while running, the result page, then the test's
report (page 1, rendered by ``pdftoppm``) and Library → Clinical Test Trend. The two earlier
visits in the trend are simulated Timed Up and Go sessions of the same subject, measured by the
``protocol`` command's path (:func:`mimucap.session.recorded.clinical_tests.run_clinical_test`) and kept
in the library as the wizard keeps its result.

``write_pairing_screenshot`` shows the offer to pair: a main window on a UDP source that hears
three emulated nodes it has not paired.
"""

from __future__ import annotations

import shutil
import socket
import subprocess
import threading
from pathlib import Path

from PyQt5 import QtWidgets
from screenshots_common import known_mounting_calibration
from screenshots_common import wait as _wait

#: (file, recorded UTC, simulator seed) of the subject's earlier Timed Up and Go visits.
EARLIER_VISITS = (
    ("P001_2026-08-24_trial01.h5", "2026-08-24T09:30:00+00:00", 16),
    ("P001_2026-10-05_trial01.h5", "2026-10-05T09:40:00+00:00", 3),
)
#: The subject as the clinician enters them on the choice page (the reference needs age and sex).
AGE_YEARS, SEX, HEIGHT_M = 72, "female", 1.75


def make_earlier_visits(library: Path) -> None:
    """The subject's earlier Timed Up and Go sessions in ``library``, measured and kept there."""
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.suit import simulate_session
    from mimucap.io.library import library_fields
    from mimucap.io.session import make_subject, session_from_simulation, write_session
    from mimucap.session.recorded.clinical_test_results import store_in_library
    from mimucap.session.recorded.clinical_tests import run_clinical_test

    for name, started, seed in EARLIER_VISITS:
        config = SimulationConfig(scenario="tug", seed=seed, height_m=HEIGHT_M, errors="ideal", random_mounting=False)
        result = simulate_session(config)
        subject = make_subject("P001", HEIGHT_M, "right", age_years=AGE_YEARS, sex=SEX)
        session = session_from_simulation(result, subject, include_truth=False)
        session.calibrations["body"] = known_mounting_calibration(result)
        session.metadata["recording"] = {"started_utc": started}
        session.metadata["library"] = library_fields("follow-up", ["balance"], "trial01")
        path = library / name
        write_session(path, session)
        note = store_in_library(path, run_clinical_test(path, "tug"), library)
        if not note.startswith("Kept"):
            raise RuntimeError(f"{name}: {note}")


def write_clinical_test_screenshots(app: QtWidgets.QApplication, window, folder: Path, out_dir: Path) -> list[Path]:
    """The guided Timed Up and Go in ``window`` (calibrated, recording into ``folder``, which
    is also its library), its report and the subject's trend, as PNGs in ``out_dir``."""
    from mimucap.gui.capture import save_window_png

    written: list[Path] = []
    make_earlier_visits(folder)
    window.library_folder = lambda: folder
    window.action_clinical_test.trigger()
    wizard = window._wizard
    wizard.choose("tug")
    wizard.age.setValue(AGE_YEARS)
    wizard.sex.setCurrentIndex(wizard.sex.findData(SEX))
    app.processEvents()
    if not wizard.ready_button.isEnabled():
        raise RuntimeError(f"the clinical test cannot start: {wizard.choice_status.text()}")
    written.append(save_window_png(wizard, out_dir / "clinical-test-1-choice.png"))
    wizard.ready_button.click()
    live = window.live
    _wait(app, lambda: live.simulator.current_activity() == "sit", 60, "the subject seated")
    wizard.countdown_button.click()
    procedure = wizard.procedure
    _wait(app, lambda: procedure.state == "countdown" and procedure.countdown_left_s(live.time_s) < 2.0, 30,
          "the countdown")
    app.processEvents()
    written.append(save_window_png(wizard, out_dir / "clinical-test-2-countdown.png"))
    _wait(app, lambda: procedure.state != "countdown" and (procedure.state != "running"
                                                           or procedure.elapsed_s(live.time_s) > 5.0), 60,
          "the test running")
    app.processEvents()
    written.append(save_window_png(wizard, out_dir / "clinical-test-3-running.png"))
    _wait(app, lambda: wizard.result is not None or "No result" in wizard.result_status.text(), 300, "the result")
    if wizard.result is None:
        raise RuntimeError(wizard.result_status.text())
    app.processEvents()
    written.append(save_window_png(wizard, out_dir / "clinical-test-4-result.png"))
    pdf = folder / "tug-report.pdf"
    wizard.write_report(pdf)
    if shutil.which("pdftoppm"):
        subprocess.run(["pdftoppm", "-r", "80", "-png", str(pdf), str(out_dir / "clinical-test-report-page")],
                       check=True)
        written += sorted(out_dir.glob("clinical-test-report-page-*.png"))
    wizard.close()

    window.show_workspace("library")
    library = window.library_view
    library.wait_for_scan()
    library.select_subject("P001")
    trend = library.open_trend()
    app.processEvents()
    written.append(save_window_png(trend, out_dir / "clinical-test-trend.png"))
    trend.close()
    window.show_workspace("capture")
    return written


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def write_pairing_screenshot(app: QtWidgets.QApplication, out_dir: Path) -> list[Path]:
    """The window's offer to pair three emulated UDP nodes it hears (their data refused until
    paired); call with a scratch home folder (the pairings file is there)."""
    from mimucap.acquisition.emulate_common import EmulatorSettings
    from mimucap.acquisition.emulate_motion import SimulatorMotion
    from mimucap.acquisition.emulate_udp import UdpEmulator
    from mimucap.gui.capture import save_window_png
    from mimucap.gui.main_window import MainWindow

    port = _free_udp_port()
    window = MainWindow(f"udp:127.0.0.1:{port}")
    window.show()
    window.start()
    settings = EmulatorSettings(n_sensors=3, first_sensor_id=4, seed=2)
    node = UdpEmulator(settings, ("127.0.0.1", port), SimulatorMotion(3, settings.rate_hz, "walk", 2))
    stop = threading.Event()
    threading.Thread(target=node.run, args=(stop,), daemon=True).start()
    try:
        _wait(app, lambda: window._pair_dialog is not None and len(window._unpaired) == 3, 60, "the offer to pair")
        if window._pair_dialog.list.count() < 3:  # offered when the first node was heard: offer all three
            window._pair_dialog.reject()
            _wait(app, lambda: window._pair_dialog is not None and window._pair_dialog.list.count() == 3, 20,
                  "the offer to pair all three")
        dialog = window._pair_dialog
        app.processEvents()
        path = save_window_png(dialog, out_dir / "pair-devices-offer.png")
        dialog.reject()
    finally:
        stop.set()
        window.close()
    return [path]
