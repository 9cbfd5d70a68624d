"""The paired suit on disk: pairing adds each device once with its label and time, unpairing
removes it, the file sits beside the calibrations, and a damaged, foreign or newer file is an
error naming the file (never an empty suit)."""

from __future__ import annotations

import json

import pytest

from mimucap.io.calibration_store import CalibrationStore, user_data_dir
from mimucap.io.pairing_store import PairingFileError, PairingStore


def test_pairing_adds_each_device_once_and_unpairing_removes_it(tmp_path):
    store = PairingStore(tmp_path / "paired_devices.json")
    assert store.devices() == [] and store.device_ids() == frozenset()
    assert store.pair([("mac:02000000000A", "1"), ("mac:A1B2C3D4E5F6/0", "A1B2C3D4E5F6-0")]) == [
        "mac:02000000000A", "mac:A1B2C3D4E5F6/0"]
    assert store.pair([("mac:02000000000A", "7")]) == []                 # paired already: kept as it was
    again = PairingStore(store.path)
    assert [(d.device_id, d.label) for d in again.devices()] == [("mac:02000000000A", "1"),
                                                                 ("mac:A1B2C3D4E5F6/0", "A1B2C3D4E5F6-0")]
    assert again.devices()[0].paired_utc.endswith("Z")
    assert again.devices()[1].describe() == "sensor 0 of MAC A1:B2:C3:D4:E5:F6 (heard as sensor A1B2C3D4E5F6-0)"
    assert again.unpair(["mac:02000000000A", "mac:020000000099"]) == ["mac:02000000000A"]
    assert again.device_ids() == frozenset({"mac:A1B2C3D4E5F6/0"})
    with pytest.raises(ValueError, match="not a device id"):
        again.pair([("A1B2C3D4E5F6", "1")])


def test_the_suit_is_kept_beside_the_calibrations():
    assert PairingStore().path.parent == user_data_dir() == CalibrationStore().directory.parent.parent


@pytest.mark.parametrize(("text", "message"), [
    ("{not json", "corrupt pairings file"),
    (json.dumps({"format": "something-else"}), "not a MimuCap pairings file"),
    (json.dumps({"format": "mimucap-pairings", "format_version": 9, "devices": []}), "newer than this MimuCap reads"),
    (json.dumps({"format": "mimucap-pairings", "format_version": 1, "devices": [{"device_id": "x"}]}),
     "device 1: 'x' is not a device id"),
])
def test_a_damaged_foreign_or_newer_file_is_an_error_naming_it(tmp_path, text, message):
    path = tmp_path / "paired_devices.json"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(PairingFileError, match=message) as error:
        PairingStore(path).device_ids()
    assert str(path) in str(error.value)
