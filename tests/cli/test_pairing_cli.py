"""Pairing over loopback UDP with the real commands (``mimucap pair``, ``record``, ``emulate``):
only the paired suit's nodes are recorded; another node on the network is refused, counted and
named, and ``pair listen`` pairs what it hears."""

from __future__ import annotations

import signal
import subprocess

import pytest

from mimucap.acquisition.emulate_common import node_mac
from mimucap.cli import main
from mimucap.core.device_identity import mac_device_id
from mimucap.io.pairing_store import PairingStore
from mimucap.io.session import read_session
from tests.cli.test_record_cli import MIMUCAP, free_udp_port, wait_until_bound


def _emulate(port: int, *options: str, duration_s: float = 2.5) -> subprocess.Popen:
    return subprocess.Popen(MIMUCAP + ["emulate", "udp", "--rate", "100", "--target", f"127.0.0.1:{port}",
                                       "--duration", str(duration_s), *options],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.slow
def test_a_paired_node_records_and_an_unpaired_one_is_refused_and_counted(tmp_path):
    ours = [mac_device_id(node_mac(0, k)) for k in (1, 2)]       # nodes 1 and 2 of the suit of seed 0
    stranger = mac_device_id(node_mac(7, 3))                      # node 3 of another suit
    assert main(["pair", "add", *ours]) == 0
    port = free_udp_port()
    out = tmp_path / "paired.h5"
    # the recording ends when the nodes are done (SIGTERM ends it early and writes the file)
    record = subprocess.Popen(MIMUCAP + ["record", "--source", f"udp:127.0.0.1:{port}", "--duration", "120",
                                         "--out", str(out), "--quiet"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_until_bound(port)
    emulators = [_emulate(port, "--sensors", "2"), _emulate(port, "--sensors", "1", "--first-id", "3", "--seed", "7")]
    for emulator in emulators:
        assert emulator.wait(60) == 0, emulator.stderr.read()
    record.send_signal(signal.SIGTERM)
    _stdout, stderr = record.communicate(timeout=60)
    assert record.returncode == 0, stderr

    session = read_session(out)
    assert sorted(session.sensors) == ["1", "2"]                   # node 3 never reaches the recording
    assert {sensor: device.device_id for sensor, device in session.devices().items()} == dict(zip("12", ours))
    for stream in session.sensors.values():
        assert 200 <= len(stream) <= 260                          # 2.5 s at 100 Hz: the paired nodes whole
    udp = session.metadata["acquisition"]["sources"]["udp"]
    refused = udp["unpaired"]["3"]
    assert refused["device"] == {"device_id": stranger}
    assert 200 <= refused["refused"] <= 260                        # each of node 3's samples, counted
    assert udp["rejections"]["unpaired_device"] >= refused["refused"]
    assert set(udp["unpaired"]) == {"3"}
    assert stranger[4:] in stderr.replace(":", "") and f"mimucap pair listen --source udp:127.0.0.1:{port}" in stderr


@pytest.mark.slow
def test_pair_listen_pairs_the_devices_it_hears_and_remove_unpairs_them():
    port = free_udp_port()
    listen = subprocess.Popen(MIMUCAP + ["pair", "listen", "--source", f"udp:127.0.0.1:{port}", "--duration", "6"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_until_bound(port)
    emulator = _emulate(port, "--sensors", "2", "--first-id", "5", "--seed", "3", duration_s=30)
    try:
        stdout, stderr = listen.communicate(timeout=60)
    finally:
        emulator.terminate()
        emulator.wait(30)
    assert listen.returncode == 0, stderr
    heard = [mac_device_id(node_mac(3, k)) for k in (5, 6)]
    assert PairingStore().device_ids() == frozenset(heard)
    assert [device.label for device in PairingStore().devices()] == ["5", "6"]
    assert all(f"paired: {device_id}" in stdout for device_id in heard)
    assert main(["pair", "remove", heard[0]]) == 0
    assert PairingStore().device_ids() == frozenset(heard[1:])
    assert main(["pair", "remove", heard[0]]) == 1                # not paired any more: said, not ignored


def test_pair_listen_refuses_a_source_that_needs_no_pairing(capsys):
    assert main(["pair", "listen", "--source", "simulated"]) == 1
    assert "need no pairing" in capsys.readouterr().err
