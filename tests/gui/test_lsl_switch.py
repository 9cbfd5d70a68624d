"""File → Stream to Lab Streaming Layer in the main window: the live session's streams appear,
another program's marker stream the user picks becomes session markers, the streams follow a
new source, and without pylsl the switch says how to install it."""

from __future__ import annotations

import uuid

import pytest
from PyQt5 import QtWidgets

from mimucap.gui.main_window import MainWindow
from mimucap.session.streaming import lsl_clock


@pytest.fixture
def window(qtbot):
    win = MainWindow("simulated:demo")
    qtbot.addWidget(win)
    win.show()
    win.start()
    yield win
    win.close()


def test_the_switch_streams_and_takes_the_picked_marker_stream(window, qtbot, monkeypatch):
    pylsl = pytest.importorskip("pylsl", reason="pylsl is not installed (pip install 'mimucap[lsl]'; make test installs it)")
    name = f"Clicks {uuid.uuid4().hex[:8]}"
    clicks = pylsl.StreamOutlet(pylsl.StreamInfo(name, "Markers", 1, 0, "string", f"clicks-{name}"))
    offered = []

    def pick(_parent, _title, _label, items, *_args):
        offered.extend(items)
        return name, True

    monkeypatch.setattr(QtWidgets.QInputDialog, "getItem", pick)
    qtbot.waitUntil(lambda: window.live.started, timeout=60000)
    window.lsl_switch.action.trigger()
    assert window.lsl_switch.action.isChecked()
    assert name in offered and not any(item.startswith("MimuCap") for item in offered)
    streamer = window.lsl_switch.streamer
    assert streamer.marker_stream == name
    qtbot.waitUntil(lambda: streamer.segments.outlet is not None, timeout=10000)  # opens with its rate
    found = pylsl.resolve_bypred(f"source_id='{streamer.segments.layout.source_id}'", 1, 10.0)
    assert found and found[0].type() == "MoCap"
    seen = []
    window.live.events.marker.connect(lambda t_s, label, _recorded: seen.append((t_s, label)))
    stamp = pylsl.local_clock()
    clicks.push_sample(["button"], stamp)
    qtbot.waitUntil(lambda: len(seen) > 0, timeout=5000)
    t_s, label = seen[0]
    assert label == "button" and abs(streamer.lsl_time(t_s) - stamp) < 0.010

    window.open_source("simulated:walk", interactive=False)   # the streams follow the new source
    follower = window.lsl_switch.streamer
    assert follower is not None and follower is not streamer and follower.session is window.live
    assert follower.marker_stream == name and window.lsl_switch.action.isChecked()
    window.lsl_switch.action.trigger()
    assert window.lsl_switch.streamer is None and not window.lsl_switch.action.isChecked()


def test_without_pylsl_the_switch_says_how_to_install_it(window, monkeypatch):
    def missing():
        raise lsl_clock.LslMissing(f"{lsl_clock.INSTALL_HINT} (test)")

    said = []
    monkeypatch.setattr(lsl_clock, "load_pylsl", missing)
    monkeypatch.setattr(QtWidgets.QMessageBox, "information", lambda _parent, _title, text: said.append(text))
    window.lsl_switch.action.trigger()
    assert not window.lsl_switch.action.isChecked() and window.lsl_switch.streamer is None
    assert "pip install 'mimucap[lsl]'" in said[0]
