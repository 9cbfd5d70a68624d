"""Sample intake: session membership, stale sequence numbers, bounded bookkeeping of strangers."""

from __future__ import annotations

from mimucap.acquisition.intake import MAX_TRACKED_UNKNOWN, IntakeSettings, SampleIntake
from mimucap.acquisition.samples import Sample


def test_strangers_are_counted_in_bounded_memory_and_stale_samples_refused():
    messages = []
    intake = SampleIntake("udp", IntakeSettings(sensor_ids=(1,), sensor_names=((1, "pelvis"),)), messages.append)
    for sensor_id in range(2, 2002):                          # 2000 ids that are not in the session
        assert not intake.accept(Sample(sensor_id=sensor_id, seq=0, device_time_s=1.0), 1.0)
    assert len(intake.unknown) == MAX_TRACKED_UNKNOWN + 1      # 256 named, the rest lumped as "other"
    assert sum(intake.unknown.values()) == 2000
    assert intake.rejections.as_dict() == {"unknown_sensor": 2000}
    for seq in (10, 11, 11, 9, 12, 2**32 - 1):                 # a duplicate, a late one, a far-back one
        intake.accept(Sample(sensor_id=1, seq=seq, device_time_s=1.0 + seq * 0.01), 2.0 + seq * 0.01)
    intake.flush()
    (block,) = messages[0].unpacked()
    assert block.sensor_id == "pelvis"
    assert block.seq.tolist() == [10, 11, 12]
    assert intake.rejections["stale_sequence"] == 3


def test_sequence_numbers_unwrap_across_the_32_bit_boundary():
    messages = []
    intake = SampleIntake("udp", IntakeSettings(), messages.append)
    for k, seq in enumerate((2**32 - 2, 2**32 - 1, 0, 1)):
        assert intake.accept(Sample(sensor_id=7, seq=seq, device_time_s=5.0 + k * 0.01), 10.0 + k * 0.01)
    intake.flush()
    (block,) = messages[0].unpacked()
    assert block.seq.tolist() == [2**32 - 2, 2**32 - 1, 2**32, 2**32 + 1]
