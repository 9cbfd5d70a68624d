"""Calibration wizards: magnetometer (:class:`MagnetometerWizard`) and body
(:class:`BodyCalibrationWizard`). Both are dialogs over the Qt-free procedures of
:mod:`mimucap.session.procedures.magnetometer` and :mod:`mimucap.session.procedures.body`; the
main window opens them with ``(parent, live_session)``."""

from mimucap.gui.wizards.body import BodyCalibrationWizard
from mimucap.gui.wizards.magnetometer import MagnetometerWizard

__all__ = ["BodyCalibrationWizard", "MagnetometerWizard"]
