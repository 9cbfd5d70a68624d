"""The one record of a sensor's samples: joining, selecting, restamping and checking it."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core.sensor_samples import SensorSamples, concatenate_samples, join_per_sensor


def _part(first: int, n: int, *, mag: bool = True, calibration: bool = False, sensor: str = "S01") -> SensorSamples:
    seq = np.arange(first, first + n)
    return SensorSamples(
        sensor, 0.01 * seq, seq, acc=np.tile([0.0, 0.0, 9.81], (n, 1)), gyr=np.full((n, 3), 0.1),
        mag_uT=np.tile([20.0, 0.0, -40.0], (n, 1)) if mag else None,
        calibration=np.tile(np.array([3, 3, 2, 1], dtype=np.int8), (n, 1)) if calibration else None,
        device_time_s=5.0 + 0.01 * seq, source="udp", segment="pelvis", extra={"temp_degC": np.full(n, 30.0)})


def test_parts_join_in_order_keeping_every_array():
    joined = concatenate_samples([_part(0, 3), _part(3, 4)])
    assert joined.seq.tolist() == list(range(7)) and joined.t_s.shape == (7,)
    assert joined.mag_uT.shape == (7, 3) and joined.device_time_s.shape == (7,) and joined.receive_time_s is None
    assert (joined.source, joined.segment, joined.extra["temp_degC"].shape) == ("udp", "pelvis", (7,))


def test_a_channel_some_parts_lack_is_refused_dropped_or_filled_never_zeroed():
    parts = [_part(0, 2, calibration=True), _part(2, 3, mag=False)]
    with pytest.raises(ValueError, match="sensor S01: mag_uT is present in some"):
        concatenate_samples(parts)
    dropped = concatenate_samples(parts, missing="drop")
    assert dropped.mag_uT is None and dropped.calibration is None and dropped.acc.shape == (5, 3)
    filled = concatenate_samples(parts, missing="fill")
    assert np.isnan(filled.mag_uT[2:]).all() and np.isfinite(filled.mag_uT[:2]).all()
    assert filled.calibration.dtype == np.int8
    np.testing.assert_array_equal(filled.calibration, [[3, 3, 2, 1]] * 2 + [[-1, -1, -1, -1]] * 3)
    with pytest.raises(ValueError, match="S01 with those of S02"):
        concatenate_samples([_part(0, 2), _part(2, 2, sensor="S02")])
    with pytest.raises(ValueError, match="no samples"):
        concatenate_samples([])


def test_one_poll_joins_each_sensor_s_blocks_of_one_channel_set():
    poll = [_part(0, 1), _part(0, 2, sensor="S02"), _part(1, 1), _part(3, 0), _part(2, 2, mag=False), _part(2, 1, sensor="S02")]
    joined = join_per_sensor(poll)
    assert [(s.sensor_id, s.seq.tolist(), s.mag_uT is not None) for s in joined] == [
        ("S01", [0, 1], True), ("S02", [0, 1, 2], True), ("S01", [2, 3], False)]
    assert join_per_sensor([]) == []


def test_rows_select_every_per_sample_array_alike():
    samples = _part(0, 6)
    picked = samples.rows(np.array([True, False, True, False, False, True]))
    assert picked.seq.tolist() == [0, 2, 5] and picked.extra["temp_degC"].shape == (3,)
    np.testing.assert_array_equal(picked.device_time_s, samples.device_time_s[[0, 2, 5]])
    assert picked.q_world_from_sensor is None and picked.segment == "pelvis"
    assert len(samples.rows(slice(1, 3))) == 2


def test_restamped_samples_share_their_arrays():
    samples = _part(0, 4)
    moved = samples.with_times(samples.t_s - 1.0)
    np.testing.assert_allclose(moved.t_s, samples.t_s - 1.0)
    assert moved.acc is samples.acc and moved.extra is samples.extra and moved.channels() == ("acc", "gyr", "mag_uT")


def test_checked_samples_are_converted_and_bad_shapes_name_the_sensor():
    checked = SensorSamples.checked("S07", [0, 1, 2], np.arange(3, dtype=np.int32), acc=[[0, 0, 9]] * 3,
                                    calibration=np.zeros((3, 4), dtype=np.int64))
    assert checked.t_s.dtype == np.float64 and checked.seq.dtype == np.int64 and checked.acc.dtype == np.float64
    assert checked.calibration.dtype == np.int8
    for fields, message in [
        (dict(t_s=np.zeros((3, 1)), seq=np.arange(3)), r"sensor S07: t_s must have shape \(N,\)"),
        (dict(t_s=np.zeros(3), seq=np.arange(4)), r"sensor S07: seq must be an integer array of shape \(3,\)"),
        (dict(t_s=np.zeros(3), seq=np.arange(3), q_world_from_sensor=np.zeros((3, 3))),
         r"sensor S07: q_world_from_sensor must have shape \(3, 4\)"),
        (dict(t_s=np.zeros(3), seq=np.arange(3), calibration=np.zeros((3, 4))), "sensor S07: calibration must be an integer"),
        (dict(t_s=np.zeros(3), seq=np.arange(3), extra={"temp_degC": np.zeros(2)}),
         "sensor S07: extra channel temp_degC must have 3 rows"),
    ]:
        with pytest.raises(ValueError, match=message):
            SensorSamples.checked("S07", **fields)
    with pytest.raises(ValueError, match="sensor id 'a/b' is not usable as a name"):
        SensorSamples.checked("a/b", np.zeros(1), np.zeros(1, dtype=int))
