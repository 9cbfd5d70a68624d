"""File → Stream to Lab Streaming Layer: the window's switch for the live session's LSL streams.

Turned on, the live session's outputs go out as LSL streams and, when the user picks one, the
markers of another program's LSL marker stream come in as session markers
(:class:`~mimucap.session.streaming.lsl_streamer.LslStreamer` does both; this only shows and forwards). The streams
follow the window's source: a new source gets its own streams. Without pylsl the switch says
how to install it and stays off.
"""

from __future__ import annotations

from PyQt5 import QtWidgets

NO_MARKERS = "(no marker stream)"


class LslSwitch:
    """The checkable action ``action`` in ``menu`` of ``window``; :meth:`follow` is told the
    window's live session (``None`` when it has none)."""

    def __init__(self, window: QtWidgets.QMainWindow, menu: QtWidgets.QMenu) -> None:
        self.window = window
        self.action = menu.addAction("S&tream to Lab Streaming Layer…")
        self.action.setCheckable(True)
        self.action.setToolTip("Publish segment orientations, joint angles, raw samples and markers as LSL "
                               "streams (LabRecorder records them beside EEG, EMG, force plates), and take "
                               "another program's LSL markers as session markers")
        self.action.triggered.connect(self._toggled)
        self.streamer = None
        self._session = None
        #: the switch is on: the streams go to every live session the window gets
        self._wanted = False
        self._marker_stream = ""

    def follow(self, session) -> None:
        """The window's live session is now ``session``: streams move to it (or close while it
        has none, and open again with the next)."""
        if self.streamer is not None:
            self._marker_stream = self.streamer.marker_stream
        self._close()
        self._session = session
        if self._wanted and session is not None:
            self._open(self._marker_stream)

    def _toggled(self, on: bool) -> None:
        if not on:
            self._wanted = False
            self._marker_stream = ""
            self._close()
            self.window.statusBar().showMessage("Lab Streaming Layer streams closed", 5000)
            return
        from mimucap.session.streaming.lsl_clock import LslMissing, load_pylsl

        try:
            load_pylsl()
        except LslMissing as error:
            self.action.setChecked(False)
            QtWidgets.QMessageBox.information(self.window, "Lab Streaming Layer", str(error))
            return
        if self._session is None:
            self.action.setChecked(False)
            return
        self._open("")
        if self.streamer is None:
            return
        self._wanted = True
        names = self.streamer.marker_streams()
        if names:
            name, chosen = QtWidgets.QInputDialog.getItem(
                self.window, "Lab Streaming Layer", "Take markers from the LSL stream:", [NO_MARKERS, *names], 0, False)
            if chosen and name != NO_MARKERS:
                self.take_markers(name)
        self._say()

    def take_markers(self, name: str) -> None:
        """Take the LSL marker stream ``name`` as session markers (a message says why not)."""
        try:
            self.streamer.take_markers(name)
        except (ValueError, RuntimeError) as error:
            QtWidgets.QMessageBox.warning(self.window, "Lab Streaming Layer", str(error))

    def _open(self, marker_stream: str) -> None:
        from mimucap.session.streaming.lsl_streamer import LslStreamer

        try:
            self.streamer = LslStreamer(self._session)
        except (ValueError, RuntimeError, OSError) as error:
            self._wanted = False
            self.action.setChecked(False)
            QtWidgets.QMessageBox.warning(self.window, "Lab Streaming Layer", f"Cannot open the LSL streams: {error}")
            return
        self.action.setChecked(True)
        if marker_stream:
            self.take_markers(marker_stream)

    def _say(self) -> None:
        markers = f"; markers from '{self.streamer.marker_stream}'" if self.streamer.marker_stream else ""
        self.window.statusBar().showMessage(f"Streaming to Lab Streaming Layer as 'MimuCap …'{markers}", 10000)

    def _close(self) -> None:
        if self.streamer is not None:
            self.streamer.close()
        self.streamer = None
        self.action.setChecked(self._wanted)
