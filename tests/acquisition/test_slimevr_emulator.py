"""The SlimeVR source against trackers no one here wrote: the npm package
``@slimevr/tracker-emulation`` (installed with the machine's npm into a cache folder outside the
repository, ``$XDG_CACHE_HOME/mimucap-test/npm``, and reused), driven by
``slimevr_trackers.mjs``. The trackers talk to the real product path: ``open_live_session``
with a ``slimevr:`` spec, the acquisition worker process and the live pipeline."""

from __future__ import annotations

import json
import math
import os
import shutil
import socket
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from mimucap.core.device_identity import mac_device_id
from mimucap.io.pairing_store import PairingStore
from mimucap.session.live.live_session import open_live_session
from mimucap.session.live.sensor_rows import STALE_AFTER_S

PACKAGE = "@slimevr/tracker-emulation@0.2.6"
SCRIPT = Path(__file__).with_name("slimevr_trackers.mjs")
TRACKERS, SENSORS, RATE_HZ = 3, 2, 50


def _cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "mimucap-test" / "npm"


@pytest.fixture(scope="module")
def emulation_modules() -> Path:
    """The folder whose ``node_modules`` holds the emulator (installed on first use)."""
    if shutil.which("node") is None or shutil.which("npm") is None:
        pytest.skip("Node.js (node and npm) is not installed: the SlimeVR tracker emulator cannot run")
    folder = _cache_dir()
    marker = folder / "node_modules" / "@slimevr" / "tracker-emulation" / "package.json"
    if not marker.exists():
        folder.mkdir(parents=True, exist_ok=True)
        try:
            done = subprocess.run(["npm", "install", "--no-audit", "--no-fund", "--prefix", str(folder), PACKAGE],
                                  capture_output=True, text=True, timeout=180)
        except subprocess.TimeoutExpired:
            pytest.skip(f"npm could not install {PACKAGE} within 180 s (no registry access?)")
        if done.returncode != 0 or not marker.exists():
            pytest.skip(f"npm could not install {PACKAGE}: {done.stderr.strip().splitlines()[-1:]}")
    return folder


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


class Trackers:
    """The node process and the JSON events it prints (read by a thread)."""

    def __init__(self, modules: Path, port: int) -> None:
        self.process = subprocess.Popen(
            ["node", str(SCRIPT), str(modules), "--port", str(port), "--trackers", str(TRACKERS),
             "--sensors", str(SENSORS), "--rate", str(RATE_HZ)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.events: list[tuple[float, dict]] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self.events.append((time.monotonic(), json.loads(line)))

    def command(self, text: str) -> None:
        self.process.stdin.write(text + "\n")
        self.process.stdin.flush()

    def wait_for(self, event: str, count: int = 1, timeout_s: float = 10.0, pump=None) -> list[tuple[float, dict]]:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            found = [e for e in self.events if e[1]["event"] == event]
            if len(found) >= count:
                return found
            if self.process.poll() is not None and not self._reader.is_alive():
                raise AssertionError(f"the tracker emulator ended: {self.process.stderr.read()}")
            if pump is not None:
                pump()
            time.sleep(0.01)
        raise AssertionError(f"no {count} '{event}' event(s) from the tracker emulator in {timeout_s} s")

    def close(self) -> None:
        if self.process.poll() is None:
            try:
                self.command("quit")
                self.process.wait(timeout=5)
            except (OSError, subprocess.TimeoutExpired):
                self.process.kill()
                self.process.wait()


def expected_q_world_from_sensor(t: int, s: int, k: np.ndarray) -> np.ndarray:
    """The rotation k of sensor s of tracker t that the script sends, as ``q_world_from_sensor``
    (K, 4) scalar first: a turn by 2h about the unit axis a of the tracker's z-up frame, which
    the documented conversion (the identity, docs/protocols.md) leaves as it is."""
    h = 0.01 * k + 0.2 * t + 0.1 * s
    b = 0.7 * t + 1.3 * s
    a = np.array([math.cos(b), math.sin(b), 0.5])
    a /= np.linalg.norm(a)
    return np.column_stack([np.cos(h), np.sin(h)[:, None] * a])


@pytest.mark.slow
def test_emulated_trackers_through_the_live_pipeline(emulation_modules):
    port = _free_udp_port()
    names = [f"024D430000{t + 1:02X}-{s}" for t in range(TRACKERS) for s in range(SENSORS)]
    PairingStore().pair((mac_device_id(name[:12], int(name[-1])), name) for name in names)   # our suit
    live = open_live_session(f"slimevr:127.0.0.1:{port}")
    received: dict[str, list[np.ndarray]] = {}
    live.events.blocks.connect(lambda blocks: [received.setdefault(b.sensor_id, []).append(b.q_world_from_sensor)
                                                for b in blocks])
    live.start()
    trackers = Trackers(emulation_modules, port)
    try:
        # handshake: every tracker finds this server (it answers as SlimeVR-Server does)
        trackers.wait_for("connected", TRACKERS, timeout_s=20.0, pump=live.step)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and set(live.sensor_ids) != set(names):
            live.step()
            time.sleep(0.01)
        assert sorted(live.sensor_ids) == sorted(names)
        end = time.monotonic() + 1.0
        while time.monotonic() < end:
            live.step()
            time.sleep(0.01)
        rows = {row.sensor_id: row for row in live.sensor_rows()}
        for t in range(TRACKERS):
            for s in range(SENSORS):
                row = rows[f"024D430000{t + 1:02X}-{s}"]
                assert not row.stale and row.rate_hz > 0.5 * RATE_HZ
                assert row.battery_pct == pytest.approx(80 - 5 * t, abs=1e-3)
                assert row.signal_dbm == -50 - t
                assert row.mag_cal == "on-board"        # orientation-only: it fuses on board
                assert row.drops == 0                    # loopback loses nothing
        # a tracker that stops is flagged stale within STALE_AFTER_S of its last packet
        trackers.command("stop 1")
        (stopped_at, stopped), = trackers.wait_for("stopped", pump=live.step)
        stale_after = None
        while time.monotonic() < stopped_at + 3.0:
            live.step()
            rows = {row.sensor_id: row for row in live.sensor_rows()}
            if all(rows[f"024D43000002-{s}"].stale for s in range(SENSORS)):
                stale_after = time.monotonic() - stopped_at
                break
            time.sleep(0.01)
        assert stale_after is not None and stale_after <= STALE_AFTER_S + 0.25
        assert not any(rows[f"024D430000{t + 1:02X}-{s}"].stale for t in (0, 2) for s in range(SENSORS))
        trackers.command("quit")
        (_, done), = trackers.wait_for("done", pump=live.step)
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            live.step()
            time.sleep(0.01)
    finally:
        trackers.close()
        live.stop()
    # every rotation arrived, unchanged but for float32 precision, in order
    for t in range(TRACKERS):
        for s in range(SENSORS):
            q = np.concatenate(received[f"024D430000{t + 1:02X}-{s}"])
            assert len(q) == done["sent"][t][s]
            expected = expected_q_world_from_sensor(t, s, np.arange(len(q)))
            angle = 2 * np.arccos(np.clip(np.abs(np.sum(q * expected, axis=1)), 0, 1))
            assert np.max(angle) < 1e-6        # float32 on the wire: about 1e-7 rad
