"""The window offers to pair a device the network source heard and refused, and takes its data
once it is paired (loopback UDP, an emulated node)."""

from __future__ import annotations

import threading

from PyQt5 import QtCore, QtWidgets

from mimucap.acquisition.emulate_common import EmulatorSettings, node_mac
from mimucap.acquisition.emulate_udp import UdpEmulator
from mimucap.core.device_identity import mac_device_id
from mimucap.io.pairing_store import PairingStore
from tests.acquisition.conftest import SyntheticMotion
from tests.acquisition.test_udp_loopback import free_udp_port


def test_an_unpaired_node_is_offered_for_pairing_and_records_once_paired(qtbot):
    from mimucap.gui.main_window import MainWindow

    port = free_udp_port()
    win = MainWindow(f"udp:127.0.0.1:{port}")
    qtbot.addWidget(win)
    win.show()
    win.start()
    stop = threading.Event()
    node = UdpEmulator(EmulatorSettings(n_sensors=1, first_sensor_id=4, seed=2), ("127.0.0.1", port),
                       SyntheticMotion(1, 100.0))
    threading.Thread(target=node.run, args=(stop,), daemon=True).start()
    device_id = mac_device_id(node_mac(2, 4))
    try:
        qtbot.waitUntil(lambda: win._pair_dialog is not None, timeout=30000)   # offered when first heard
        dialog = win._pair_dialog
        assert dialog.isVisible()
        item = dialog.list.item(0)
        assert dialog.list.count() == 1 and "sensor 4" in item.text() and "MAC 02:" in item.text()
        assert item.checkState() == QtCore.Qt.Checked and dialog.pair_button.isEnabled()
        assert win.live.sensor_ids == ()                     # refused until paired: no sensor in the table
        assert win.action_pair.isEnabled()
        dialog.reject()                                        # "Not Now": not asked again by itself...
        qtbot.wait(1000)
        assert win._pair_dialog is None and PairingStore().device_ids() == frozenset()
        win.action_pair.trigger()                              # ...but Session → Pair Devices… offers it again
        dialog = win._pair_dialog
        assert dialog is not None and dialog.isVisible() and dialog.list.count() == 1
        qtbot.mouseClick(dialog.pair_button, QtCore.Qt.LeftButton)
        assert PairingStore().device_ids() == {device_id}
        assert [d.label for d in PairingStore().devices()] == ["4"]
        qtbot.waitUntil(lambda: "4" in win.live.sensor_ids, timeout=30000)   # the source opened again lets it in
        assert win.live.devices["4"].device_id == device_id
        assert win._pair_dialog is None and not win.action_pair.isEnabled()
    finally:
        stop.set()
        win.close()


def test_the_offer_lists_a_device_that_cannot_be_paired_without_a_box(qtbot):
    from mimucap.acquisition.pairing import UnpairedSensor
    from mimucap.acquisition.hello import NO_HELLO
    from mimucap.core.device_identity import SensorDevice
    from mimucap.gui.source_dialog import PairDevicesDialog

    old = UnpairedSensor("7", SensorDevice(None, NO_HELLO), 40)
    new = UnpairedSensor("8", SensorDevice("mac:02A1B2C3D4E5"), 12)
    dialog = PairDevicesDialog(None, "udp:0.0.0.0:5555", [old, new])
    qtbot.addWidget(dialog)
    assert not dialog.list.item(0).flags() & QtCore.Qt.ItemIsEnabled
    assert "older than the hello" in dialog.list.item(0).text()
    assert dialog.chosen() == [new]
    dialog.list.item(1).setCheckState(QtCore.Qt.Unchecked)
    assert dialog.chosen() == []
    # Every device's whole line is in view (the MAC is what to check), said in words
    dialog.show()
    qtbot.waitExposed(dialog)
    assert dialog.list.viewport().width() >= dialog.list.sizeHintForColumn(0)
    assert dialog.list.horizontalScrollBar().maximum() == 0
    assert "(12 packets refused)" in dialog.list.item(1).text()
    # named by the device (what its label says), the name it sends under and the address secondary
    assert dialog.list.item(1).text().startswith("MAC 02:A1:B2:C3:D4:E5 — sends as sensor 8")
    first_line = dialog.findChildren(QtWidgets.QLabel)[0].text()
    assert first_line.startswith("The wireless receiver (UDP port 5555) hears devices") and "0.0.0.0" not in first_line
    assert dialog.findChild(QtWidgets.QLabel, "pairSourceAddress").text() == "Source: udp:0.0.0.0:5555"
    one = PairDevicesDialog(None, "udp:0.0.0.0:5555", [UnpairedSensor("9", SensorDevice("mac:02A1B2C3D4E6"), 1)])
    qtbot.addWidget(one)
    assert one.list.item(0).text().endswith("(1 packet refused)")
    only_old = PairDevicesDialog(None, "udp:0.0.0.0:5555", [old])
    qtbot.addWidget(only_old)
    assert not only_old.pair_button.isEnabled()
