"""Sample intake: session membership, stale sequence numbers, bounded bookkeeping of strangers."""

from __future__ import annotations

from mimucap.acquisition.intake import MAX_TRACKED_UNKNOWN, IntakeSettings, SampleIntake
from mimucap.acquisition.rejections import Rejection
from mimucap.acquisition.wire_sample import RefusedSample, Sample


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


def test_a_rebooted_node_continues_without_stale_refusals_or_false_drops():
    messages = []
    intake = SampleIntake("udp", IntakeSettings(), messages.append)
    for k in range(100):                                    # running for a while: clock at 100 s
        assert intake.accept(Sample(sensor_id=3, seq=5000 + k, device_time_s=100.0 + k * 0.01), 50.0 + k * 0.01)
    for k in range(50):                                     # reboot: counter and clock start over
        assert intake.accept(Sample(sensor_id=3, seq=k, device_time_s=0.2 + k * 0.01), 51.5 + k * 0.01)
    intake.flush()
    blocks = [b for m in messages for b in m.unpacked()]
    seq = [int(v) for b in blocks for v in b.seq]
    host = [float(v) for b in blocks for v in b.t_s]
    assert seq == list(range(5000, 5150))                   # continuous: no false drops
    assert all(b > a for a, b in zip(host, host[1:]))
    assert abs(host[100] - 51.5) < 1e-6                     # the new clock maps onto the host again
    assert intake.report("running").node_restarts == {"3": 1}
    assert not intake.rejections.as_dict()


def test_refused_samples_are_rejections_of_their_sensor_and_not_drops():
    """A NaN or out-of-range sample of a known sensor is counted against that sensor, and the
    sequence number it leaves free is reported in ``refused_in_gaps`` (so the drop count of the
    supervisor, gaps less refused, stays at the real losses)."""
    messages = []
    intake = SampleIntake("udp", IntakeSettings(sensor_ids=(1,), sensor_names=((1, "pelvis"),)),
                          messages.append)
    intake.refuse(RefusedSample(1, 0, Rejection.NON_FINITE))        # before any accepted: no gap
    for seq in range(1, 20):
        if seq in (5, 6, 12):
            intake.refuse(RefusedSample(1, seq, Rejection.NON_FINITE))
        elif seq == 9:
            intake.refuse(RefusedSample(1, seq, Rejection.OUT_OF_RANGE))
        elif seq == 15:
            continue                                                 # a real loss
        else:
            assert intake.accept(Sample(sensor_id=1, seq=seq, device_time_s=1.0 + seq * 0.01),
                                 2.0 + seq * 0.01)
    intake.refuse(RefusedSample(1, 12, Rejection.NON_FINITE))       # a stale duplicate
    intake.refuse(RefusedSample(1, 25, Rejection.NON_FINITE))       # pending: no later sample yet
    intake.refuse(RefusedSample(4, 3, Rejection.NON_FINITE))        # not a sensor of the session
    intake.flush()
    report = intake.report("running")
    assert report.refused_in_gaps == {"pelvis": 4}                   # 5, 6, 9 and 12
    assert report.rejections_by_sensor == {"pelvis": {"non_finite": 6, "out_of_range": 1}}
    assert report.rejections == {"non_finite": 6, "out_of_range": 1, "unknown_sensor": 1}
    assert report.unknown_sensors == {"id 4": 1}
    seqs = [int(v) for m in messages for b in m.unpacked() for v in b.seq]
    gaps = seqs[-1] - seqs[0] + 1 - len(seqs)
    assert gaps - report.refused_in_gaps["pelvis"] == 1              # only seq 15 was lost
