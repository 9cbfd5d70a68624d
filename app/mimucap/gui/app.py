"""Start the desktop application: display check, QApplication, main window, screenshot mode."""

from __future__ import annotations

import os
import sys
from pathlib import Path

NO_DISPLAY_MESSAGE = "mimucap gui: no display found; run it under a virtual screen: xvfb-run -a mimucap gui"


def has_display(environ=None) -> bool:
    """True when Qt can open windows: an X or Wayland display, or an explicit Qt platform."""
    env = os.environ if environ is None else environ
    return any(env.get(name) for name in ("DISPLAY", "WAYLAND_DISPLAY", "QT_QPA_PLATFORM"))


def _log_to_file(path: Path) -> None:
    """Warnings and errors of the application also go to ``path`` (in the platform's log folder)."""
    import logging

    handler = logging.FileHandler(path, encoding="utf-8")
    handler.setLevel(logging.INFO)
    handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    root = logging.getLogger("mimucap")
    root.setLevel(logging.INFO)
    root.addHandler(handler)


def _report_uncaught_errors(log_path: Path) -> None:
    """An error escaping a Qt slot goes to the log and, in one line, to the status bar of the
    active window (what it did before: printed on the terminal only, which a clinician never
    sees); the previous hook still runs."""
    import logging

    from PyQt5 import QtWidgets

    previous = sys.excepthook

    def hook(kind, value, traceback) -> None:
        logging.getLogger("mimucap").error("unexpected error", exc_info=(kind, value, traceback))
        window = QtWidgets.QApplication.activeWindow()
        if isinstance(window, QtWidgets.QMainWindow):
            window.statusBar().showMessage(f"Unexpected error: {value} (details in {log_path})", 15000)
        previous(kind, value, traceback)

    sys.excepthook = hook


def run_gui(source: str | None = None, screenshot: str | Path | None = None, after_s: float = 3.0,
            review: str | Path | None = None) -> int:
    """Open the main window on ``source`` (default: the last one chosen) and run the event
    loop; return the exit code.

    With ``review``, that recorded session opens in the Review workspace. With
    ``screenshot``, the window (3D view included; showing the session when ``review`` is given)
    is written to that PNG ``after_s`` seconds after live data started (and the session is shown; after the first-start
    preparation of the filters, if any) and the application quits with 0.
    """
    if not has_display():
        print(NO_DISPLAY_MESSAGE, file=sys.stderr)
        return 1
    if after_s < 0 or after_s != after_s:
        raise ValueError(f"--after must be a number of seconds >= 0, got {after_s}")
    from PyQt5 import QtCore, QtGui, QtWidgets

    from mimucap.acquisition.source_spec import parse_source_spec
    from mimucap.gui.main_window import MainWindow
    from mimucap.gui.settings import log_dir
    from mimucap.resources import resource_path

    log_path = log_dir() / "mimucap.log"
    _log_to_file(log_path)
    _report_uncaught_errors(log_path)

    if source is not None:
        parse_source_spec(source)  # a bad spec is a one-line error before any window opens
    if review is not None and not Path(review).is_file():
        raise FileNotFoundError(f"session file not found: {review}")
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([sys.argv[0]])
    app.setApplicationName("MimuCap")
    app.setOrganizationName("MimuCap")
    app.setDesktopFileName("mimucap")  # matches packaging/mimucap.desktop
    app.setWindowIcon(QtGui.QIcon(str(resource_path("icons/mimucap.svg"))))
    window = MainWindow(source)
    if window.live is None:
        message = window.source_error or f"cannot open source {source}"
        window.close()
        raise ValueError(message)
    window.show()
    window.start()
    shown = window.open_review(review) if review is not None else window
    outcome = {"code": 0}
    if screenshot is not None:
        def shoot() -> None:
            try:
                if shown is not window and shown.load_error is not None:
                    raise OSError(f"cannot review {review}: {shown.load_error}")
                window.save_screenshot(screenshot)
            except OSError as error:
                print(f"mimucap gui: error: {error}", file=sys.stderr)
                outcome["code"] = 1
            window.close()
            app.quit()

        def shoot_when_started() -> None:
            loading = shown is not window and not shown.ready and shown.load_error is None
            if window.starting or loading:
                QtCore.QTimer.singleShot(100, shoot_when_started)
            else:
                QtCore.QTimer.singleShot(int(round(after_s * 1000)), shoot)

        shoot_when_started()
    app.exec_()
    window.close()
    window.deleteLater()
    app.processEvents()  # the VTK context is released while Qt is still alive
    return outcome["code"]
