"""The crash-safe journal: records survive, damage in the middle is stepped over (the reader
resynchronises on the next record with a valid checksum) and a torn tail is cut."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mimucap.io.journal.file import (
    RESYNC_DIRECT_CHECK_BYTES, RESYNC_WINDOW_BYTES, DamagedSpan, JournalError, JournalWriter, read_journal,
)

HEADER_BYTES = 12


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


def write_journal(path, payloads, kind=1):
    """A journal of ``payloads``; returns the byte offset where each record starts and ends."""
    writer = JournalWriter(path, flush_interval_s=1.0, fsync=False)
    starts, ends = [], []
    for payload in payloads:
        starts.append(writer.bytes_written)
        writer.append(kind, payload)
        ends.append(writer.bytes_written)
    writer.close()
    return starts, ends


def expected_reading(starts, ends, file_bytes, bad):
    """What the reader must find when the records whose index is in ``bad`` are damaged:
    the intact indices, the skipped spans and whether the tail is torn."""
    intact = [i for i in range(len(starts)) if i not in bad and ends[i] <= file_bytes]
    spans, previous_end = [], HEADER_BYTES
    for count, i in enumerate(intact):
        if starts[i] > previous_end:
            spans.append(DamagedSpan(previous_end, starts[i] - previous_end, count))
        previous_end = ends[i]
    return intact, spans, previous_end < file_bytes


@settings(max_examples=60, deadline=None)
@given(st.lists(st.binary(max_size=64), min_size=1, max_size=20), st.data())
def test_truncation_or_corruption_loses_only_the_records_it_hits(tmp_path_factory, payloads, data):
    path = tmp_path_factory.mktemp("j") / "t.journal"
    starts, ends = write_journal(path, payloads)
    raw = path.read_bytes()
    cut = data.draw(st.integers(HEADER_BYTES, len(raw)))
    damaged = bytearray(raw[:cut])
    flip = data.draw(st.none() | st.integers(HEADER_BYTES, max(HEADER_BYTES, cut - 1)))
    if flip is not None and flip < len(damaged):
        damaged[flip] ^= 0xFF
    path.write_bytes(bytes(damaged))
    contents = read_journal(path)
    hit = {i for i in range(len(payloads)) if flip is not None and starts[i] <= flip < ends[i]}
    intact, spans, torn = expected_reading(starts, ends, len(damaged), hit)
    assert [p for _k, p in contents.records] == [payloads[i] for i in intact]
    assert contents.skipped == spans
    assert contents.torn == torn
    assert contents.valid_bytes == (ends[intact[-1]] if intact else HEADER_BYTES)
    assert contents.discarded_bytes == len(damaged) - sum(ends[i] - starts[i] for i in intact) - HEADER_BYTES


def test_flipped_bytes_in_the_middle_cost_only_the_records_they_hit(tmp_path):
    path = tmp_path / "m.journal"
    payloads = [bytes([i % 251]) * (300 + 7 * i) for i in range(60)]
    starts, ends = write_journal(path, payloads, kind=2)
    raw = bytearray(path.read_bytes())
    first, last = starts[20] + 50, starts[22] + 30            # 200-odd bytes over records 20..22
    for offset in range(first, last):
        raw[offset] ^= 0x5A
    path.write_bytes(bytes(raw))
    contents = read_journal(path)
    assert [p for _k, p in contents.records] == payloads[:20] + payloads[23:]
    assert contents.skipped == [DamagedSpan(starts[20], starts[23] - starts[20], 20)]
    assert contents.records_after(contents.skipped[0]) == 37
    assert not contents.torn and contents.damaged
    assert contents.discarded_bytes == starts[23] - starts[20]


def test_a_wild_length_in_damaged_bytes_does_not_swallow_the_records_after_it(tmp_path):
    path = tmp_path / "w.journal"
    payloads = [bytes([i]) * 100 for i in range(40)]
    starts, ends = write_journal(path, payloads)
    raw = bytearray(path.read_bytes())
    # record 5 claims to run over the next 20 records (a plausible length that fits the file)
    raw[starts[5]:starts[5] + 4] = (ends[25] - starts[5] - 8).to_bytes(4, "little")
    path.write_bytes(bytes(raw))
    contents = read_journal(path)
    assert [p for _k, p in contents.records] == payloads[:5] + payloads[6:]
    assert contents.skipped == [DamagedSpan(starts[5], starts[6] - starts[5], 5)]


def test_garbage_between_records_is_skipped_exactly(tmp_path):
    path = tmp_path / "g.journal"
    payloads = [b"sample block %d" % i * 20 for i in range(30)]
    starts, ends = write_journal(path, payloads)
    raw = path.read_bytes()
    garbage = bytes(range(256)) * 3 + b"\x10\x00\x00\x00junk"      # even a short record header
    path.write_bytes(raw[:starts[12]] + garbage + raw[starts[12]:])
    contents = read_journal(path)
    assert [p for _k, p in contents.records] == payloads
    assert contents.skipped == [DamagedSpan(starts[12], len(garbage), 12)]
    assert contents.records_after(contents.skipped[0]) == 18 and not contents.torn


def test_damage_then_a_torn_tail_are_reported_apart(tmp_path):
    path = tmp_path / "t.journal"
    payloads = [bytes([i]) * 50 for i in range(20)]
    starts, ends = write_journal(path, payloads)
    raw = bytearray(path.read_bytes())
    raw[starts[4] + 20] ^= 0xFF
    path.write_bytes(bytes(raw[:ends[-1] - 10]))              # the last record is torn
    contents = read_journal(path)
    assert [p for _k, p in contents.records] == payloads[:4] + payloads[5:19]
    assert contents.skipped == [DamagedSpan(starts[4], starts[5] - starts[4], 4)]
    assert contents.torn and contents.torn_bytes == ends[-1] - 10 - starts[19]


def test_long_records_after_damage_are_found(tmp_path):
    """Records longer than the direct-check size are found by their chain of headers, and
    (deferred) also when a torn tail follows them."""
    path = tmp_path / "l.journal"
    size = RESYNC_DIRECT_CHECK_BYTES + 1000
    payloads = [bytes([i]) * 40 for i in range(3)] + [bytes([200 + i]) * size for i in range(4)]
    starts, ends = write_journal(path, payloads)
    raw = bytearray(path.read_bytes())
    raw[starts[2] + 15] ^= 0xFF                                  # damages the short record 2
    path.write_bytes(bytes(raw))
    contents = read_journal(path)
    assert [p for _k, p in contents.records] == payloads[:2] + payloads[3:]
    assert contents.skipped == [DamagedSpan(starts[2], starts[3] - starts[2], 2)]
    raw[starts[4] + 100] ^= 0xFF                                 # and a long one, then tear the tail
    path.write_bytes(bytes(raw[:ends[-1] - 5]))
    contents = read_journal(path)
    assert [p for _k, p in contents.records] == payloads[:2] + [payloads[3], payloads[5]]
    assert contents.skipped == [DamagedSpan(starts[2], starts[3] - starts[2], 2),
                                DamagedSpan(starts[4], starts[5] - starts[4], 3)]
    assert contents.torn and contents.valid_bytes == ends[5]


def test_resynchronising_over_several_windows_of_garbage(tmp_path):
    path = tmp_path / "r.journal"
    payloads = [b"before", b"after", b"last"]
    starts, _ends = write_journal(path, payloads)
    raw = path.read_bytes()
    garbage = np.random.default_rng(1).integers(0, 256, 3 * RESYNC_WINDOW_BYTES + 17, dtype=np.uint8).tobytes()
    path.write_bytes(raw[:starts[1]] + garbage + raw[starts[1]:])
    contents = read_journal(path)
    assert [p for _k, p in contents.records] == payloads
    assert contents.skipped == [DamagedSpan(starts[1], len(garbage), 1)]


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
        "from mimucap.io.journal.file import JournalWriter\n"
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
