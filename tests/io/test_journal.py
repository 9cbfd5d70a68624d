"""The crash-safe journal: records survive, a torn tail is cut at the first bad record."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mimucap.io.journal import JournalError, JournalWriter, read_journal


def test_records_round_trip(tmp_path):
    path = tmp_path / "a.journal"
    writer = JournalWriter(path, flush_interval_s=0.2)
    payloads = [bytes([i]) * (i * 37 % 500) for i in range(200)]
    for i, payload in enumerate(payloads):
        writer.append(i % 7, payload)
    writer.close()
    contents = read_journal(path)
    assert not contents.torn and contents.discarded_bytes == 0
    assert contents.records == [(i % 7, p) for i, p in enumerate(payloads)]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.binary(max_size=64), min_size=1, max_size=20), st.data())
def test_truncation_or_corruption_keeps_every_record_before_the_damage(tmp_path_factory, payloads, data):
    path = tmp_path_factory.mktemp("j") / "t.journal"
    writer = JournalWriter(path, flush_interval_s=1.0, fsync=False)
    ends = []
    for payload in payloads:
        writer.append(1, payload)
        ends.append(writer.bytes_written)
    writer.close()
    raw = path.read_bytes()
    header = 12
    cut = data.draw(st.integers(header, len(raw)))
    damaged = bytearray(raw[:cut])
    flip = data.draw(st.none() | st.integers(header, max(header, cut - 1)))
    if flip is not None and flip < len(damaged):
        damaged[flip] ^= 0xFF
    path.write_bytes(bytes(damaged))
    contents = read_journal(path)
    first_bad = min([cut] + ([flip] if flip is not None and flip < cut else []))
    intact = sum(1 for end in ends if end <= first_bad)
    assert [p for _k, p in contents.records] == payloads[:intact]
    assert contents.valid_bytes == (ends[intact - 1] if intact else header)
    assert contents.torn == (contents.valid_bytes < len(damaged))


def test_a_foreign_file_is_refused_with_its_name(tmp_path):
    path = tmp_path / "not.journal"
    path.write_bytes(b"hello world, not a journal")
    with pytest.raises(JournalError, match="not.journal"):
        read_journal(path)


def test_an_existing_journal_is_never_overwritten(tmp_path):
    path = tmp_path / "x.journal"
    JournalWriter(path).close()
    with pytest.raises(FileExistsError):
        JournalWriter(path)


def test_kill_9_loses_at_most_the_last_flush_interval(tmp_path):
    """A writer process killed hard keeps every record written more than 1 s before."""
    path = tmp_path / "k.journal"
    script = (
        "import sys, time\n"
        "from mimucap.io.journal import JournalWriter\n"
        f"w = JournalWriter({str(path)!r}, flush_interval_s=0.5)\n"
        "i = 0\n"
        "while True:\n"
        "    w.append(2, repr((i, time.monotonic())).encode())\n"
        "    i += 1\n"
        "    time.sleep(0.002)\n"
    )
    process = subprocess.Popen([sys.executable, "-c", script])
    try:
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and (not path.exists() or path.stat().st_size < 20_000):
            time.sleep(0.05)
        time.sleep(0.3)
        killed_at = time.monotonic()
        os.kill(process.pid, 9)
    finally:
        process.wait(10)
    contents = read_journal(path)
    assert len(contents.records) > 100
    last_index, last_time = eval(contents.records[-1][1])  # noqa: S307 - our own repr
    assert killed_at - last_time <= 1.0
    assert [eval(p)[0] for _k, p in contents.records] == list(range(last_index + 1))  # noqa: S307
