"""Stride classification, bouts and turns of a long recording: the same results as on its
parts, in time that grows no faster than n log n (the long sequence below has over 24 000 strides;
pairwise comparisons make 6·10⁸ of them).

The short walk repeats with a pause between the copies, so that every copy is classified as if
it were alone. Times are multiples of 1/64 s and copies 64 s apart, so shifting is exact."""

from __future__ import annotations

import math
from dataclasses import replace

from mimucap.core.analysis.strides import Interval, Stride, bouts_and_turns, classify

STEP = 1.0 / 64.0
PERIOD_S = 64.0


def walk(offset_s: float = 0.0) -> tuple[list[Stride], list[Interval]]:
    """A short walk of both feet: regular strides, a pause, a stride of the right foot whose
    middle swing was not seen, a missing final contact, a turning stride by its heading, two
    strides inside a turn found beforehand."""
    stride_s = 70 * STEP
    left_ic = [k * stride_s for k in range(10)] + [14.0 + k * stride_s for k in range(6)]
    right_ic = [35 * STEP + k * stride_s for k in range(16) if k not in (5,)]
    strides = []
    for side, ics in (("left", left_ic), ("right", right_ic)):
        for k in range(len(ics) - 1):
            ic, next_ic = ics[k], ics[k + 1]
            fc = next_ic - 28 * STEP
            heading = 6.0
            if side == "left" and k == 3:
                fc = math.nan
            if side == "left" and k == 6:
                heading = 70.0
            strides.append(Stride(side, offset_s + ic, offset_s + fc, offset_s + next_ic, 1.25, heading))
    strides.sort(key=lambda s: (s.ic_s, s.side))
    turns = [Interval(offset_s + 16.0, offset_s + 18.5, 0, 150.0)]
    return strides, turns


def shifted(strides: list[Stride], by_s: float) -> list[Stride]:
    return [replace(s, ic_s=s.ic_s + by_s, fc_s=s.fc_s + by_s, next_ic_s=s.next_ic_s + by_s) for s in strides]


def reason_words(strides: list[Stride]) -> list[str]:
    return [s.refused_because.split(":")[0].split(" ")[0] for s in strides]


def test_a_short_walk_is_classified_as_before():
    strides, turns = walk()
    found = classify(strides, turns=turns)
    # What the pairwise classification gave for this walk.
    assert reason_words(found) == [
        "", "", "", "", "", "", "no", "", "", "irregular", "", "turning", "", "", "", "ends", "", "4.16", "", "", "",
        "", "", "", "", "ends", "turning", "turning", "ends"]
    numbered, bouts, counted = bouts_and_turns(found, turns=turns)
    assert [(b.start_s, b.end_s, b.n_strides) for b in bouts] == [(0.0, 19.46875, 28)]
    assert [t.n_strides for t in counted] == [5]
    _, _, by_heading = bouts_and_turns(found)
    assert [(t.start_s, t.end_s, t.angle_deg) for t in by_heading] == [(6.5625, 7.65625, 70.0), (16.1875, 18.375, 12.0)]


def test_a_long_recording_is_classified_as_its_parts():
    strides, turns = walk()
    part = classify(strides, turns=turns)
    numbered_part, bouts_part, counted_part = bouts_and_turns(part, turns=turns)
    _, _, heading_part = bouts_and_turns(part)
    copies = 840
    long_strides = [s for k in range(copies) for s in shifted(strides, k * PERIOD_S)]
    long_turns = [replace(t, start_s=t.start_s + k * PERIOD_S, end_s=t.end_s + k * PERIOD_S)
                  for k in range(copies) for t in turns]
    found = classify(long_strides, turns=long_turns)
    assert len(found) == copies * len(part) > 24_000
    n = len(part)
    for k in (0, 1, copies // 2, copies - 1):
        copy = found[k * n:(k + 1) * n]
        assert [(s.analysed, s.straight) for s in copy] == [(s.analysed, s.straight) for s in part]
        assert reason_words(copy) == reason_words(part)
    assert sum(s.analysed for s in found) == copies * sum(s.analysed for s in part)
    numbered, bouts, counted = bouts_and_turns(found, turns=long_turns)
    assert len(bouts) == copies * len(bouts_part)
    assert [s.bout for s in numbered[-n:]] == [b + (copies - 1) * len(bouts_part) if b >= 0 else -1
                                                 for b in (s.bout for s in numbered_part)]
    assert [t.n_strides for t in counted] == [t.n_strides for t in counted_part] * copies
    _, _, by_heading = bouts_and_turns(found)
    assert [t.angle_deg for t in by_heading] == [t.angle_deg for t in heading_part] * copies
    assert [t.start_s for t in by_heading[-len(heading_part):]] == [t.start_s + (copies - 1) * PERIOD_S
                                                                  for t in heading_part]
