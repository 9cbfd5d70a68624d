"""Joining the packed blocks of one poll: each sensor comes out once, its rows in order."""

from __future__ import annotations

import numpy as np

from mimucap.acquisition.packed_blocks import BlockBuilder, join_packed_blocks
from mimucap.acquisition.wire_sample import Sample


def _message(builder: BlockBuilder, rows) -> list:
    for name, seq, with_mag in rows:
        sample = Sample(sensor_id=0, seq=seq, device_time_s=0.01 * seq, acc=(0.0, 0.0, 9.81),
                        gyr=(0.001 * seq, 0.0, 0.0), mag_uT=(20.0, 0.0, -40.0) if with_mag else None)
        builder.add(name, seq, sample, 100.0 + 0.01 * seq, 100.0 + 0.01 * seq + 0.002)
    return builder.take()


def test_messages_of_one_worker_join_into_one_block_per_channel_set_in_row_order():
    builder = BlockBuilder("udp")
    first = _message(builder, [("pelvis", 1, True), ("thigh_r", 1, True), ("pelvis", 2, True)])
    second = _message(builder, [("thigh_r", 2, True), ("shank_r", 1, True), ("pelvis", 3, True)])  # a new sensor
    third = _message(builder, [("pelvis", 4, False), ("thigh_r", 3, True)])  # pelvis loses its magnetometer
    joined = join_packed_blocks(first + second + third)
    assert len(joined) == 2  # with and without magnetometer
    with_mag = {block.sensor_id: block for block in joined[0].unpack()}
    assert joined[0].sensor_ids == ("pelvis", "thigh_r", "shank_r")
    assert with_mag["pelvis"].seq.tolist() == [1, 2, 3]
    assert with_mag["thigh_r"].seq.tolist() == [1, 2, 3]
    assert with_mag["shank_r"].seq.tolist() == [1]
    np.testing.assert_allclose(with_mag["thigh_r"].gyr[:, 0], [0.001, 0.002, 0.003])
    np.testing.assert_allclose(with_mag["pelvis"].t_s, [100.01, 100.02, 100.03])
    (without_mag,) = joined[1].unpack()
    assert without_mag.sensor_id == "pelvis" and without_mag.seq.tolist() == [4] and without_mag.mag_uT is None


def test_blocks_of_other_sources_or_unrelated_sensor_lists_stay_apart():
    one, other = BlockBuilder("udp:a"), BlockBuilder("udp:b")
    a = _message(one, [("pelvis", 1, True)])
    b = _message(other, [("thigh_r", 1, True)])
    restarted = BlockBuilder("udp:a")  # a restarted worker numbers its sensors afresh
    c = _message(restarted, [("shank_r", 1, True), ("pelvis", 2, True)])
    joined = join_packed_blocks(a + b + c)
    assert [block.source for block in joined] == ["udp:a", "udp:b", "udp:a"]
    assert [[s.sensor_id for s in block.unpack()] for block in joined] == [["pelvis"], ["thigh_r"], ["shank_r", "pelvis"]]
    assert join_packed_blocks([]) == []


def test_every_channel_and_clock_lands_in_its_field_of_the_unpacked_samples():
    builder = BlockBuilder("udp")
    for seq in (5, 6):
        sample = Sample(sensor_id=3, seq=seq, device_time_s=2.0 + seq, acc=(1.0, 2.0, 3.0), gyr=(4.0, 5.0, 6.0),
                        mag_uT=(7.0, 8.0, 9.0), q_world_from_sensor=(0.0, 1.0, 0.0, 0.0),
                        calibration=(3, 2, 1, 0), battery_pct=42.0)
        builder.add("S03", seq, sample, 10.0 + seq, 20.0 + seq)
    (samples,) = builder.take()[0].unpack()
    assert (samples.sensor_id, samples.source, samples.segment, samples.extra) == ("S03", "udp", None, None)
    assert samples.seq.tolist() == [5, 6] and samples.t_s.tolist() == [15.0, 16.0]
    assert samples.device_time_s.tolist() == [7.0, 8.0] and samples.receive_time_s.tolist() == [25.0, 26.0]
    for name, row in (("acc", [1, 2, 3]), ("gyr", [4, 5, 6]), ("mag_uT", [7, 8, 9]),
                      ("q_world_from_sensor", [0, 1, 0, 0]), ("calibration", [3, 2, 1, 0])):
        np.testing.assert_array_equal(getattr(samples, name), [row, row], err_msg=name)
    assert samples.calibration.dtype == np.int8 and samples.battery_pct.tolist() == [42.0, 42.0]
