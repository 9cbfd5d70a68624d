"""A stored magnetometer calibration belongs to its device, and one that no longer fits is not
good wherever readiness is shown (the measured problem: after ``magcal fit --save`` of one
simulated session, another suit numbered S01… took the calibrations, and a stale one got a
green tick).

* Another suit numbered alike (another seed): it takes none of them; the sensor table, the
  checklist, the recording's readiness and the library say so, naming the sensors.
* The same suit in another room (a field of 85 µT instead of 49.3): the calibrations apply, and
  each is named as not good with its figures, in the table, the checklist, the recording and
  the library.
* A device that changes under a sensor id (another node answering to it) loses the calibration
  made on the first one.
"""

from __future__ import annotations

import re

import pytest

from mimucap.cli import main
from mimucap.core.simulate.config import SimulationConfig
from mimucap.core.simulate.magnetic_field import EarthField
from mimucap.io.calibration_store import CalibrationStore
from mimucap.io.library import _verdicts
from mimucap.io.session import read_session
from mimucap.session.feeds import SimulatorFeed
from mimucap.session.live import LiveSession
from mimucap.session.recording_checklist import recording_checklist

SEED = 5


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """The store after ``magcal fit --save`` of a simulated demo session of the seed-5 suit."""
    folder = tmp_path_factory.mktemp("calibrated")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MIMUCAP_DATA_DIR", str(folder / "data"))
        session = folder / "demo.h5"
        assert main(["simulate", "--scenario", "demo", "--duration", "30", "--seed", str(SEED),
                     "--out", str(session)]) == 0
        assert main(["magcal", "fit", str(session), "--save"]) == 0
        store = CalibrationStore()
    assert store.sensor_ids() == [f"S{k:02d}" for k in range(1, 11)]
    return store


def live_on(config: SimulationConfig, store: CalibrationStore):
    now = [0.0]
    clock = lambda: now[0]  # noqa: E731
    session = LiveSession(SimulatorFeed(config, clock=clock), clock=clock, calibration_store=store,
                          status_clock=clock)
    session.start()
    return session, now


def run(session, now, seconds: float) -> None:
    for _ in range(int(seconds / 0.02)):
        now[0] += 0.02
        session.step()


def record(session, now, path):
    session.start_recording(path, {"id": "P1"})
    run(session, now, 0.5)
    session.stop_recording()
    return read_session(path)


def test_another_suit_numbered_alike_takes_none_of_the_stored_calibrations(calibrated, tmp_path):
    config = SimulationConfig(scenario="npose")                    # the app's suit: seed 0
    session, now = live_on(config, calibrated)
    assert session.mag_calibrations == {}
    stored_suit = SimulationConfig(seed=SEED).device_ids()["S01"].split("/")[0].removeprefix("sim:")
    this_suit = config.device_ids()["S01"].split("/")[0].removeprefix("sim:")
    note = session.calibration_problems["S01"]
    assert note.startswith(f"the calibration stored under S01 is of simulated unit S01 of suit {stored_suit} (")
    assert note.endswith(f"this sensor is simulated unit S01 of suit {this_suit}: not used, calibrate it here")
    run(session, now, 1.0)
    rows = {row.sensor_id: row for row in session.sensor_rows()}
    assert rows["S01"].mag_cal == "not calibrated" and rows["S01"].mag_cal_note == note
    items = {item.key: item for item in recording_checklist(session)}
    assert not items["magnetometers"].ok
    assert items["magnetometers"].text == ("not calibrated, the stored calibration is another device's: "
                                           "Pelvis sensor (S01), Thorax sensor (S02) and 8 more")
    recorded = record(session, now, tmp_path / "other-suit.h5")
    assert recorded.metadata["devices"]["S01"] == {"device_id": config.device_ids()["S01"]}
    assert recorded.metadata["magnetometer_readiness"]["S01"] == {"level": "not calibrated", "problems": [note]}
    assert _verdicts(recorded.metadata, recorded.calibrations)["magnetometer S01"] == "not calibrated"


def test_the_same_suit_in_another_room_is_named_not_good_with_its_figures(calibrated, tmp_path):
    config = SimulationConfig(scenario="npose", seed=SEED, earth_field=EarthField(magnitude_uT=85.0))
    session, now = live_on(config, calibrated)
    assert sorted(session.mag_calibrations) == [f"S{k:02d}" for k in range(1, 11)]   # its own devices
    run(session, now, 2.5)
    s01 = session.mag_calibrations["S01"]
    rows = {row.sensor_id: row for row in session.sensor_rows()}
    standing = rows["S01"].mag_standing
    assert standing.level == "not good"
    text = standing.problems[0].text
    local, when = map(int, re.fullmatch(r"local field (\d+) µT, (\d+) µT when calibrated", text).groups())
    assert when == round(s01.field_uT)
    assert abs(local - 85.0 * s01.field_uT / 49.3) <= 2.0      # the calibration's scale, in the stronger field
    assert rows["S01"].mag_field_warning == f"{text}: calibrate again here"
    assert rows["S01"].mag_cal == "calibrated" and rows["S01"].mag_cal_verdict == "good"
    item = {item.key: item for item in recording_checklist(session)}["magnetometers"]
    assert not item.ok
    assert item.text.startswith(f"the local field no longer fits: Pelvis sensor (S01) {text}; Thorax sensor (S02) "
                                "local field ")
    assert item.text.endswith(" and 8 more")
    recorded = record(session, now, tmp_path / "other-room.h5")
    readiness = recorded.metadata["magnetometer_readiness"]["S01"]
    assert readiness["level"] == "not good" and readiness["verdict"] == "good"
    assert re.fullmatch(r"local field \d+ µT, \d+ µT when calibrated", readiness["problems"][0])
    assert readiness["local_field_uT"] > 80.0
    assert recorded.calibrations["magnetometer"]["S01"]["device_id"] == config.device_ids()["S01"]
    assert _verdicts(recorded.metadata, recorded.calibrations)["magnetometer S01"] == "not good"


def test_a_calibration_leaves_with_its_device(calibrated):
    """Another node answers to S01 (the source says so): the calibration made on the first one is
    no longer applied, and the sensor is told why; the first one back, it is applied again."""
    config = SimulationConfig(scenario="npose", seed=SEED)
    session, now = live_on(config, calibrated)
    run(session, now, 0.2)
    assert "S01" in session.mag_calibrations
    own = session.feed.devices()["S01"]
    other = SimulationConfig(seed=SEED + 1).device_ids()["S01"]
    session.feed._devices["S01"] = type(own)(other)
    run(session, now, 0.2)
    assert "S01" not in session.mag_calibrations and "S02" in session.mag_calibrations
    assert "this sensor is simulated unit S01 of suit" in session.calibration_problems["S01"]
    session.feed._devices["S01"] = own
    run(session, now, 0.2)
    assert session.mag_calibrations["S01"].device_id == own.device_id and "S01" not in session.calibration_problems


def test_a_calibration_made_here_is_made_for_the_sensors_device(calibrated):
    from dataclasses import replace

    config = SimulationConfig(scenario="npose", seed=SEED + 1)
    session, _now = live_on(config, CalibrationStore(calibrated.directory.parent / "empty"))
    made = replace(calibrated.load("S02"), device_id=None)
    session.apply_mag_calibration(made, save=False)
    assert session.mag_calibrations["S02"].device_id == config.device_ids()["S02"]
    with pytest.raises(ValueError, match="was made on simulated unit S02 of suit .*: calibrate it here"):
        session.apply_mag_calibration(calibrated.load("S02"), save=False)     # made on the seed-5 suit


def test_udp_nodes_get_their_devices_calibrations_and_older_nodes_keep_theirs_unverified(tmp_path):
    """Over loopback UDP: node 1 says hello, so it takes the calibration stored for its MAC (and
    not the one stored under its id for another device); node 2 is older (no hello): once the
    source says so it takes the calibration stored under its id, and its standing says the device
    is not verified, and why."""
    import threading
    import time

    import numpy as np

    from mimucap.acquisition.emulate_common import EmulatorSettings, node_mac
    from mimucap.acquisition.emulate_udp import UdpEmulator
    from mimucap.acquisition.hello import NO_HELLO
    from mimucap.core.device_identity import mac_device_id
    from mimucap.core.magcal import MagCalibration
    from mimucap.session.live import open_live_session
    from tests.acquisition.conftest import SyntheticMotion
    from tests.acquisition.test_udp_loopback import free_udp_port

    from datetime import datetime, timezone

    made = datetime.now(timezone.utc).isoformat(timespec="seconds")

    def calibration(sensor_id, device_id):   # the synthetic nodes' field: 20 µT north, 40 µT down
        return MagCalibration(sensor_id, np.zeros(3), np.eye(3), 44.7, created_utc=made,
                              quality={"verdict": "good"}, device_id=device_id)

    store = CalibrationStore(tmp_path / "store")
    node1 = mac_device_id(node_mac(0, 1))
    store.save(calibration("1", node1))
    store.save(calibration("1", "mac:0200000000AA"))          # another node once numbered 1
    store.save(calibration("2", None))                        # made for node 2, which has no hello
    port = free_udp_port()
    live = open_live_session(f"udp:127.0.0.1:{port}", calibration_store=store)
    live.start()
    new, old = (EmulatorSettings(n_sensors=1, first_sensor_id=k, duration_s=8.0, hello=k == 1) for k in (1, 2))
    try:
        time.sleep(1.0)   # the worker binds its port
        for settings in (new, old):
            emulator = UdpEmulator(settings, ("127.0.0.1", port), SyntheticMotion(1, 100.0))
            threading.Thread(target=emulator.run, daemon=True).start()
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and set(live.mag_calibrations) != {"1", "2"}:
            live.step()
            time.sleep(0.02)
        assert set(live.mag_calibrations) == {"1", "2"}, (live.devices, live.calibration_problems)
        assert live.mag_calibrations["1"].device_id == node1 and live.mag_calibrations["2"].device_id is None
        rows = {row.sensor_id: row for row in live.sensor_rows()}
        assert rows["1"].mag_standing.warnings == ()
        assert rows["2"].device.missing == NO_HELLO
        assert rows["2"].mag_standing.summary() == f"warn: device not verified: {NO_HELLO}"
    finally:
        live.stop()
