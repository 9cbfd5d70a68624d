"""The source dialog: simulated suit (default), UDP, serial port, replay file or SlimeVR trackers.

It builds a source spec string (``simulated:demo``, ``simulated:demo@clinic``, ``udp:0.0.0.0:5555``,
``serial:/dev/ttyUSB0@115200``, ``replay:FILE@SPEED``, ``slimevr:0.0.0.0:6969``), checks it with the acquisition
layer's parser, asks which skeleton the sensors drive (ten segments, or fifteen with head,
hands and feet). :func:`remember_source` keeps both in the GUI settings once the main window
has opened the source; the dialog starts from them.

:class:`PairDevicesDialog` offers to pair the devices a network source heard but refused because
they are not paired (:mod:`mimucap.acquisition.pairing`): the main window opens it when such a
device is first heard.
"""

from __future__ import annotations

from pathlib import Path

from PyQt5 import QtCore, QtWidgets

from mimucap.acquisition.pairing import UnpairedSensor
from mimucap.acquisition.source_spec import (
    ReplaySpec, SerialSpec, SimulatedSpec, SlimeVrSpec, UdpSpec, format_source_spec, parse_source_spec,
)
from mimucap.core.simulate.names import ROOM_NAMES, SCENARIOS
from mimucap.gui.screen_fit import available_geometry
from mimucap.gui.settings import gui_settings

KINDS = ("simulated", "udp", "serial", "replay", "slimevr")
KIND_LABELS = {"simulated": "Simulated suit", "udp": "UDP (wireless nodes)", "serial": "Serial port",
               "replay": "Replay a file", "slimevr": "SlimeVR trackers"}
DEFAULT_SPEC = "simulated:demo"
DEFAULT_MODEL = "ten_segment"
MODEL_LABELS = {
    "ten_segment": "10 segments: pelvis, thorax, arms, thighs, shanks (7-10 sensors)",
    "fifteen_segment": "15 segments: also head, hands and feet (up to 17 sensors)",
}


def last_source_spec() -> str:
    """The spec chosen last time (``simulated:demo`` the first time)."""
    return str(gui_settings().value("source/spec", DEFAULT_SPEC)) or DEFAULT_SPEC


def last_skeleton_model() -> str:
    """The skeleton model chosen last time (the ten-segment one the first time)."""
    name = str(gui_settings().value("source/model", DEFAULT_MODEL))
    return name if name in MODEL_LABELS else DEFAULT_MODEL


def remember_source(spec: str, model_name: str) -> None:
    """Keep ``spec`` and ``model_name`` for the next source dialog and the next start (the
    main window calls it once the source has opened: a refused choice is not remembered)."""
    settings = gui_settings()
    settings.setValue("source/spec", spec)
    settings.setValue("source/model", model_name)
    settings.sync()


class SourceDialog(QtWidgets.QDialog):
    """Pick a source and a skeleton; :attr:`spec` and :attr:`model_name` are the result after
    ``accept()``."""

    def __init__(self, parent: QtWidgets.QWidget | None = None, spec: str | None = None,
                 model_name: str | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Choose the Source")
        self.setObjectName("sourceDialog")
        self.kind_buttons: dict[str, QtWidgets.QRadioButton] = {}
        self.stack = QtWidgets.QStackedWidget(self)
        kinds_box = QtWidgets.QVBoxLayout()
        for kind in KINDS:
            button = QtWidgets.QRadioButton(KIND_LABELS[kind], self)
            button.toggled.connect(lambda on, k=kind: on and self.stack.setCurrentIndex(KINDS.index(k)))
            self.kind_buttons[kind] = button
            kinds_box.addWidget(button)

        sim = QtWidgets.QWidget()
        self.scenario = QtWidgets.QComboBox(sim)
        self.scenario.addItems([s for s in SCENARIOS if not s.startswith("mag_")])
        self.room = QtWidgets.QComboBox(sim)
        self.room.addItems(ROOM_NAMES)
        self.room.setToolTip("clean: the earth field alone; clinic: a reinforced floor and a steel bed beside "
                             "the walkway; treadmill: walking on a treadmill")
        form = QtWidgets.QFormLayout(sim)
        form.addRow("Scenario", self.scenario)
        form.addRow("Room", self.room)
        udp, self.udp_address, self.udp_port = self._listen_page(5555)
        serial = QtWidgets.QWidget()
        self.serial_device = QtWidgets.QLineEdit("/dev/ttyUSB0", serial)
        self.serial_baud = QtWidgets.QComboBox(serial)
        self.serial_baud.setEditable(True)
        self.serial_baud.addItems(["115200", "230400", "460800", "921600", "57600"])
        form = QtWidgets.QFormLayout(serial)
        form.addRow("Device", self.serial_device)
        form.addRow("Baud rate", self.serial_baud)
        replay = QtWidgets.QWidget()
        self.replay_path = QtWidgets.QLineEdit(replay)
        browse = QtWidgets.QPushButton("Browse…", replay)
        browse.clicked.connect(self._browse)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(self.replay_path, 1)
        row.addWidget(browse)
        self.replay_speed = QtWidgets.QDoubleSpinBox(replay)
        self.replay_speed.setRange(0.1, 20.0)
        self.replay_speed.setValue(1.0)
        self.replay_speed.setSuffix(" ×")
        form = QtWidgets.QFormLayout(replay)
        form.addRow("File", row)
        form.addRow("Speed", self.replay_speed)
        slime, self.slimevr_address, self.slimevr_port = self._listen_page(6969)
        slime.layout().addRow(QtWidgets.QLabel("Close the SlimeVR server first: the trackers talk to one server.", slime))
        for page in (sim, udp, serial, replay, slime):
            self.stack.addWidget(page)

        self.model_combo = QtWidgets.QComboBox(self)
        self.model_combo.setObjectName("skeletonModel")
        for name, label in MODEL_LABELS.items():
            self.model_combo.addItem(label, name)
        self.model_combo.setCurrentIndex(self.model_combo.findData(model_name or last_skeleton_model()))
        model_row = QtWidgets.QFormLayout()
        model_row.addRow("Skeleton", self.model_combo)

        self.error_label = QtWidgets.QLabel(self)
        self.error_label.setStyleSheet("color: #b00020")
        self.error_label.setWordWrap(True)
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.Ok | QtWidgets.QDialogButtonBox.Cancel, self)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        top = QtWidgets.QHBoxLayout()
        top.addLayout(kinds_box)
        top.addWidget(self.stack, 1)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(top)
        layout.addLayout(model_row)
        layout.addWidget(self.error_label)
        layout.addWidget(buttons)
        self.spec = ""
        self.model_name = ""
        self.set_spec(spec or last_source_spec())

    @staticmethod
    def _listen_page(default_port: int) -> tuple[QtWidgets.QWidget, QtWidgets.QLineEdit, QtWidgets.QSpinBox]:
        """A page asking which address and port a network source listens on (UDP, SlimeVR)."""
        page = QtWidgets.QWidget()
        address = QtWidgets.QLineEdit("0.0.0.0", page)
        port = QtWidgets.QSpinBox(page)
        port.setRange(1, 65535)
        port.setValue(default_port)
        form = QtWidgets.QFormLayout(page)
        form.addRow("Listen on address", address)
        form.addRow("Port", port)
        return page, address, port

    def _browse(self) -> None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Replay File", "", "Sessions (*.h5);;Xsens exports (*.txt);;All files (*)")
        if path:
            self.replay_path.setText(path)

    def set_spec(self, spec: str) -> None:
        """Show ``spec`` in the controls (an unparsable one shows the default)."""
        try:
            parsed = parse_source_spec(spec)
        except ValueError:
            spec, parsed = DEFAULT_SPEC, parse_source_spec(DEFAULT_SPEC)
        kind = "simulated" if isinstance(parsed, SimulatedSpec) else spec.split(":", 1)[0]
        self.kind_buttons[kind].setChecked(True)
        self.stack.setCurrentIndex(KINDS.index(kind))
        if kind == "simulated":
            self.scenario.setCurrentText(parsed.scenario)
            self.room.setCurrentText(parsed.room)
        elif kind == "udp":
            self.udp_address.setText(parsed.bind_address)
            self.udp_port.setValue(parsed.port)
        elif kind == "serial":
            self.serial_device.setText(parsed.device)
            self.serial_baud.setCurrentText(str(parsed.baud))
        elif kind == "slimevr":
            self.slimevr_address.setText(parsed.bind_address)
            self.slimevr_port.setValue(parsed.port)
        else:
            self.replay_path.setText(str(parsed.path))
            self.replay_speed.setValue(float(parsed.speed))

    def current_kind(self) -> str:
        return next(k for k, b in self.kind_buttons.items() if b.isChecked())

    def current_spec(self) -> str:
        """The spec the controls describe (not yet validated)."""
        kind = self.current_kind()
        if kind == "simulated":
            return format_source_spec(SimulatedSpec(self.scenario.currentText(), self.room.currentText()))
        if kind == "udp":
            return f"udp:{self.udp_address.text().strip()}:{self.udp_port.value()}"
        if kind == "serial":
            return f"serial:{self.serial_device.text().strip()}@{self.serial_baud.currentText().strip()}"
        if kind == "slimevr":
            return f"slimevr:{self.slimevr_address.text().strip()}:{self.slimevr_port.value()}"
        return f"replay:{self.replay_path.text().strip()}@{self.replay_speed.value():g}"

    def accept(self) -> None:
        spec = self.current_spec()
        try:
            parse_source_spec(spec)
        except ValueError as error:
            self.error_label.setText(str(error))
            return
        self.spec = spec
        self.model_name = str(self.model_combo.currentData())
        super().accept()


def receiver_words(spec: str) -> str:
    """What hears the sensors of source ``spec``, in words ("The wireless receiver (UDP port
    5555)"); the address itself is shown beside it, secondary."""
    try:
        parsed = parse_source_spec(spec)
    except ValueError:
        return f"The source {spec}"
    if isinstance(parsed, SlimeVrSpec):
        return f"The SlimeVR receiver (UDP port {parsed.port})"
    if isinstance(parsed, UdpSpec):
        return f"The wireless receiver (UDP port {parsed.port})"
    if isinstance(parsed, SerialSpec):
        return f"The receiver on {parsed.device}"
    if isinstance(parsed, ReplaySpec):
        return f"The replayed recording {Path(parsed.path).name}"
    return "The simulated suit"


class PairDevicesDialog(QtWidgets.QDialog):
    """Offer to pair the devices of ``sensors`` that ``source`` heard and refused; after
    ``accept()``, :meth:`chosen` are the ones ticked. Devices that cannot be paired (they do not
    say which device they are) are listed with the reason, not ticked."""

    def __init__(self, parent: QtWidgets.QWidget | None, source: str, sensors: list[UnpairedSensor]) -> None:
        super().__init__(parent)
        self.setWindowTitle("Pair New Devices?")
        self.setObjectName("pairDevicesDialog")
        self.sensors = list(sensors)
        text = QtWidgets.QLabel(
            f"{receiver_words(source)} hears devices that are not paired with this suit: their data is refused. "
            "Pair your own sensors only (switch the others off, or move away from them).", self)
        text.setWordWrap(True)
        address = QtWidgets.QLabel(f"Source: {source}", self)
        address.setObjectName("pairSourceAddress")
        address.setStyleSheet("QLabel { color: #666; }")
        self.list = QtWidgets.QListWidget(self)
        for sensor in self.sensors:
            packets = "packet" if sensor.refused == 1 else "packets"
            # the device first (what to check on its label), the name it sends under second
            named = (f"{sensor.device.describe()} — sends as sensor {sensor.sensor}" if sensor.pairable
                     else sensor.describe())
            item = QtWidgets.QListWidgetItem(f"{named} ({sensor.refused} {packets} refused)")
            if sensor.pairable:
                item.setFlags(item.flags() | QtCore.Qt.ItemIsUserCheckable)
                item.setCheckState(QtCore.Qt.Checked)
            else:
                item.setFlags(item.flags() & ~QtCore.Qt.ItemIsEnabled)
                item.setToolTip("It cannot be paired: it does not say which device it is.")
            self.list.addItem(item)
        buttons = QtWidgets.QDialogButtonBox(self)
        self.pair_button = buttons.addButton("Pair", QtWidgets.QDialogButtonBox.AcceptRole)
        buttons.addButton("Not Now", QtWidgets.QDialogButtonBox.RejectRole)
        self.pair_button.setEnabled(any(sensor.pairable for sensor in self.sensors))
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        # Wide enough for every device's whole line (within the screen): the MAC is what to check.
        whole = self.list.sizeHintForColumn(0) + 2 * self.list.frameWidth() + 8
        self.list.setMinimumWidth(min(whole, available_geometry(parent).width() - 80))
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(text)
        layout.addWidget(address)
        layout.addWidget(self.list)
        layout.addWidget(buttons)

    def chosen(self) -> list[UnpairedSensor]:
        """The pairable sensors whose box is ticked."""
        return [sensor for row, sensor in enumerate(self.sensors)
                if sensor.pairable and self.list.item(row).checkState() == QtCore.Qt.Checked]
