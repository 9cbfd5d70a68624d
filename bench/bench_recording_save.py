"""Saving a stopped recording: the recorder's journal turned into the session file.

Run: ``.venv/bin/python bench/bench_recording_save.py [--minutes 10] [--sensors 17]``.

The journal is what a recording of ``--sensors`` boards at 100 Hz leaves, each board's samples
arriving in blocks of five (as the UDP boards send them), with accelerometer, gyroscope,
magnetometer and the three clocks. Timed, in this process, best of ``--repeats``:

* ``session_from_journal``: reading every record back into one record per sensor;
* ``write_session``: writing the HDF5 session file;
* the peer, a lower bound: ``h5py`` writing the same arrays straight into a file, with no
  journal to read (what saving would cost if the samples were in memory already).

Printed: the times, the samples per second saved and the ratio to the lower bound.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

from mimucap.core.sensor_samples import SensorSamples
from mimucap.io.journal.to_session import session_from_journal
from mimucap.io.session import write_session
from mimucap.session.live.recorder import Recorder, RecorderSettings

RATE_HZ = 100.0
BLOCK = 5


def make_journal(folder: Path, minutes: float, sensors: int) -> Path:
    """A closed journal of ``minutes`` of ``sensors`` boards; returns its path."""
    recorder = Recorder(folder / "session.h5", {}, RecorderSettings(fsync=False))
    recorder.start(start_host_s=0.0)
    rng = np.random.default_rng(0)
    total = int(minutes * 60.0 * RATE_HZ)
    for first in range(0, total, BLOCK):
        seq = np.arange(first, first + BLOCK, dtype=np.int64)
        t = seq / RATE_HZ
        recorder.add_blocks([
            SensorSamples(f"S{k:02d}", t, seq, acc=rng.normal(size=(BLOCK, 3)), gyr=rng.normal(size=(BLOCK, 3)),
                          mag_uT=rng.normal(size=(BLOCK, 3)), device_time_s=t, receive_time_s=t, source="bench")
            for k in range(sensors)])
    recorder.close()
    return recorder.journal_path


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--sensors", type=int, default=17)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="mimucap-save-bench-") as name:
        folder = Path(name)
        journal = make_journal(folder, args.minutes, args.sensors)
        reading, writing, bound = [], [], []
        for _ in range(args.repeats):
            started = time.perf_counter()
            session, _contents = session_from_journal(journal)
            reading.append(time.perf_counter() - started)
            started = time.perf_counter()
            write_session(folder / "out.h5", session)
            writing.append(time.perf_counter() - started)
            started = time.perf_counter()
            with h5py.File(folder / "bound.h5", "w") as handle:
                for sensor_id, stream in session.sensors.items():
                    group = handle.create_group(sensor_id)
                    for field in ("t_s", "seq", "acc", "gyr", "mag_uT", "device_time_s", "receive_time_s"):
                        if getattr(stream, field) is not None:
                            group.create_dataset(field, data=getattr(stream, field))
            bound.append(time.perf_counter() - started)
        samples = sum(len(stream) for stream in session.sensors.values())
        saving = min(reading) + min(writing)
        print(f"Saving {args.minutes:g} min of {args.sensors} sensors at {RATE_HZ:g} Hz ({samples:,} samples, "
              f"journal {journal.stat().st_size / 1e6:.0f} MB), best of {args.repeats}:")
        print(f"  session_from_journal {min(reading):6.2f} s")
        print(f"  write_session        {min(writing):6.2f} s")
        print(f"  saving in all        {saving:6.2f} s ({samples / saving / 1e6:.2f} M samples/s)")
        print(f"  h5py lower bound     {min(bound):6.2f} s (the samples already in memory; saving is "
              f"{saving / min(bound):.1f} × the bound)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
