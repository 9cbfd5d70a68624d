"""Session files: round trip, determinism and clear errors for broken or foreign files."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from mimucap.core.sensor_limits import GYR_MAX_RAD_S
from mimucap.core.sensor_samples import SensorSamples
from mimucap.io.session import (
    SESSION_FORMAT_VERSION,
    Marker,
    SensorTruth,
    Session,
    SessionFormatError,
    SessionTruth,
    gyro_range_problem,
    make_subject,
    read_metadata,
    read_session,
    write_session,
)


def _session(rng: np.random.Generator, n: int = 500) -> Session:
    t = np.arange(n) / 100.0
    s01 = SensorSamples(
        "S01", t, np.arange(n), acc=rng.normal(size=(n, 3)), gyr=rng.normal(size=(n, 3)),
        mag_uT=rng.normal(size=(n, 3)) * 40, segment="pelvis", device_time_s=t * 1.0001 + 3.0,
        extra={"temperature_degC": rng.normal(size=n)},
    )
    q = rng.normal(size=(n - 2, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    s02 = SensorSamples("S02", t[:-2], np.delete(np.arange(n), [10, 11]), q_world_from_sensor=q,
                       battery_pct=np.linspace(100, 90, n - 2))
    truth = SessionTruth(
        t_s=t,
        q_world_from_segment={"pelvis": np.tile([1.0, 0, 0, 0], (n, 1))},
        joint_angles_deg={"hip_r_flexion_deg": rng.normal(size=n)},
        sensors={"S01": SensorTruth(
            "S01", q_world_from_sensor=np.tile([0.0, 1, 0, 0], (n, 1)), segment="pelvis",
            q_segment_from_sensor=np.array([0.0, 0, 1, 0]), position_in_segment_m=np.array([0.1, 0, 0]),
            mag_A=np.eye(3) * 1.1, mag_b_uT=np.array([1.0, 2, 3]), gyr_bias_rad_s=rng.normal(size=(n, 3)),
            field_world_uT=np.tile([0, 24.65, -42.7], (n, 1)), clock_offset_s=3.0, clock_drift=1e-4,
            parameters={"gyr_scale": np.eye(3)},
        )},
        field_world_uT=np.array([0, 24.65, -42.7]),
        extra={"mag_axis_turned": np.full(n, -1)},
        attributes={"scenario": "demo"},
    )
    return Session(
        metadata={"source": {"kind": "test"}, "subject": make_subject("P1", 1.8, "left", "ok"),
                  "created_utc": "2026-01-01T00:00:00+00:00"},
        sensors={"S01": s01, "S02": s02},
        markers=[Marker(1.0, "npose"), Marker(2.5, "tpose: both")],
        truth=truth,
        calibrations={"magnetometer": {"S01": {"b_uT": [1, 2, 3], "protocol": "single_axis"}},
                      "body": {"q_segment_from_sensor": {"S01": [1, 0, 0, 0]}}},
        results={"fusion": {"S01": {"q_world_from_sensor": np.tile([1.0, 0, 0, 0], (n, 1))}},
                 "note": "filter v1", "rmse_deg": 1.5},
    )


def test_round_trip_keeps_everything(tmp_path: Path) -> None:
    session = _session(np.random.default_rng(1))
    path = write_session(tmp_path / "a.h5", session)
    back = read_session(path)
    assert back.metadata["subject"] == {"id": "P1", "height_m": 1.8, "dominance": "left", "notes": "ok"}
    assert back.metadata["source"] == {"kind": "test"}
    assert back.metadata["mimucap_version"]
    assert set(back.sensors) == {"S01", "S02"}
    for sensor_id, stream in session.sensors.items():
        other = back.sensors[sensor_id]
        for name in ("t_s", "seq", "acc", "gyr", "mag_uT", "q_world_from_sensor", "battery_pct", "device_time_s"):
            a, b = getattr(stream, name), getattr(other, name)
            assert (a is None) == (b is None), name
            if a is not None:
                np.testing.assert_array_equal(a, b)
        assert other.segment == stream.segment
    np.testing.assert_array_equal(back.sensors["S01"].extra["temperature_degC"], session.sensors["S01"].extra["temperature_degC"])
    assert back.sensors["S02"].acc is None and back.sensors["S02"].segment is None
    assert back.sensor_segments() == {"S01": "pelvis", "S02": None}
    assert back.markers == session.markers
    assert back.calibrations == session.calibrations
    np.testing.assert_array_equal(back.results["fusion"]["S01"]["q_world_from_sensor"],
                                  session.results["fusion"]["S01"]["q_world_from_sensor"])
    assert back.results["note"] == "filter v1" and float(back.results["rmse_deg"]) == 1.5
    truth, expected = back.truth, session.truth
    np.testing.assert_array_equal(truth.t_s, expected.t_s)
    np.testing.assert_array_equal(truth.joint_angles_deg["hip_r_flexion_deg"], expected.joint_angles_deg["hip_r_flexion_deg"])
    st, se = truth.sensors["S01"], expected.sensors["S01"]
    for name in ("q_world_from_sensor", "q_segment_from_sensor", "position_in_segment_m", "mag_A", "mag_b_uT",
                 "gyr_bias_rad_s", "field_world_uT"):
        np.testing.assert_array_equal(getattr(st, name), getattr(se, name))
    assert (st.segment, st.clock_offset_s, st.clock_drift) == ("pelvis", 3.0, 1e-4)
    np.testing.assert_array_equal(st.parameters["gyr_scale"], np.eye(3))
    np.testing.assert_array_equal(truth.extra["mag_axis_turned"], expected.extra["mag_axis_turned"])
    assert truth.attributes == {"scenario": "demo"}
    assert read_session(path, include_truth=False).truth is None
    assert read_metadata(path)["subject"]["id"] == "P1"


def test_units_are_attributes(tmp_path: Path) -> None:
    path = write_session(tmp_path / "u.h5", _session(np.random.default_rng(2), 50))
    with h5py.File(path, "r") as h5:
        assert h5.attrs["format"] == "mimucap-session"
        assert h5.attrs["format_version"] == SESSION_FORMAT_VERSION
        assert h5["sensors/S01/acc"].attrs["unit"] == "m/s^2"
        assert h5["sensors/S01/gyr"].attrs["unit"] == "rad/s"
        assert h5["sensors/S01/mag_uT"].attrs["unit"] == "uT"
        assert h5["truth/joint_angles_deg/hip_r_flexion_deg"].attrs["unit"] == "deg"


def test_battery_and_calibration_status_keep_the_file_s_own_form(tmp_path: Path) -> None:
    """In memory the battery is in percent and the calibration status a channel; the file keeps
    the fraction and ``extra/calibration_status`` it always had, so older files read alike."""
    n = 4
    status = np.tile(np.array([3, 2, 1, 0], dtype=np.int8), (n, 1))
    samples = SensorSamples("S01", np.arange(n) / 100.0, np.arange(n), gyr=np.zeros((n, 3)),
                            battery_pct=np.array([100.0, 90.0, 80.0, 50.0]), calibration=status)
    path = write_session(tmp_path / "b.h5", Session(sensors={"S01": samples}))
    with h5py.File(path, "r") as h5:
        np.testing.assert_array_equal(h5["sensors/S01/battery"][()], [1.0, 0.9, 0.8, 0.5])
        assert h5["sensors/S01/battery"].attrs["unit"] == "1 (fraction 0..1)"
        assert h5["sensors/S01/extra/calibration_status"].dtype == np.int8
        np.testing.assert_array_equal(h5["sensors/S01/extra/calibration_status"][()], status)
    back = read_session(path).sensors["S01"]
    np.testing.assert_allclose(back.battery_pct, [100.0, 90.0, 80.0, 50.0], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(back.calibration, status)
    assert back.extra is None and back.calibration.dtype == np.int8


def test_same_session_gives_identical_bytes(tmp_path: Path) -> None:
    first = write_session(tmp_path / "1.h5", _session(np.random.default_rng(3)))
    second = write_session(tmp_path / "2.h5", _session(np.random.default_rng(3)))
    assert first.read_bytes() == second.read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["1.h5", "2.h5"]  # no temporary files left


def test_foreign_hdf5_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "foreign.h5"
    with h5py.File(path, "w") as h5:
        h5["imu_acc"] = np.zeros((3, 3))
    with pytest.raises(SessionFormatError, match=r"foreign\.h5.*not a MimuCap session"):
        read_session(path)
    with h5py.File(path, "a") as h5:
        h5.attrs["format"] = "broad-trial"
    with pytest.raises(SessionFormatError, match="broad-trial"):
        read_session(path)


def test_text_and_truncated_files_are_refused(tmp_path: Path) -> None:
    text = tmp_path / "notes.h5"
    text.write_text("hello\n")
    with pytest.raises(SessionFormatError, match=r"notes\.h5.*not an HDF5 file"):
        read_session(text)
    good = write_session(tmp_path / "good.h5", _session(np.random.default_rng(4), 5000))
    data = good.read_bytes()
    truncated = tmp_path / "truncated.h5"
    truncated.write_bytes(data[: len(data) // 2])
    with pytest.raises(SessionFormatError, match=r"truncated\.h5"):
        read_session(truncated)
    with pytest.raises(FileNotFoundError, match="missing.h5"):
        read_session(tmp_path / "missing.h5")


def test_newer_version_and_missing_parts_are_named(tmp_path: Path) -> None:
    path = write_session(tmp_path / "v.h5", _session(np.random.default_rng(5), 20))
    with h5py.File(path, "a") as h5:
        h5.attrs["format_version"] = SESSION_FORMAT_VERSION + 1
    with pytest.raises(SessionFormatError, match=r"v\.h5.*version 2 is newer"):
        read_session(path)
    path = write_session(tmp_path / "m.h5", _session(np.random.default_rng(5), 20))
    with h5py.File(path, "a") as h5:
        del h5["sensors/S02/seq"]
    with pytest.raises(SessionFormatError, match=r"m\.h5: missing dataset /sensors/S02/seq"):
        read_session(path)
    path = write_session(tmp_path / "r.h5", _session(np.random.default_rng(5), 20))
    with h5py.File(path, "a") as h5:
        del h5["sensors/S01/gyr"]
        h5["sensors/S01/gyr"] = np.zeros((7, 3))
    with pytest.raises(SessionFormatError, match=r"/sensors/S01/gyr has 7 rows, expected 20"):
        read_session(path)
    path = write_session(tmp_path / "j.h5", _session(np.random.default_rng(5), 20))
    with h5py.File(path, "a") as h5:
        del h5["calibrations/body"]
        h5["calibrations/body"] = "{not json"
    with pytest.raises(SessionFormatError, match=r"/calibrations/body is not valid JSON"):
        read_session(path)


def test_bad_streams_and_subjects_are_rejected(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="sensor S03: acc must have shape"):
        SensorSamples.checked("S03", np.zeros(4), np.arange(4), acc=np.zeros((4, 2)))
    with pytest.raises(ValueError, match="seq must be an integer array"):
        SensorSamples.checked("S03", np.zeros(4), np.zeros(4))
    with pytest.raises(ValueError, match="height"):
        make_subject("x", 3.2)
    with pytest.raises(ValueError, match="not JSON-serialisable"):
        write_session(tmp_path / "x.h5", Session(metadata={"bad": object()}))
    with pytest.raises(OSError, match="does not exist"):
        write_session(tmp_path / "no" / "x.h5", Session())


def test_simulated_session_round_trip(tmp_path: Path) -> None:
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.suit import simulate_session
    from mimucap.io.session import session_from_simulation

    result = simulate_session(SimulationConfig(scenario="bodycal", duration_s=3.0, n_sensors=10, seed=2, drop_probability=0.05))
    back = read_session(write_session(tmp_path / "sim.h5", session_from_simulation(result)))
    assert back.metadata["source"]["scenario"] == "bodycal" and back.metadata["subject"]["height_m"] == 1.75
    for sensor_id, samples in result.samples.items():
        stream = back.sensors[sensor_id]
        np.testing.assert_array_equal(stream.mag_uT, samples.mag_uT)
        np.testing.assert_array_equal(stream.seq, samples.seq)
        assert stream.segment == result.mounting[sensor_id].segment
        truth = back.truth.sensors[sensor_id]
        np.testing.assert_array_equal(truth.mag_A, result.parameters[sensor_id].mag_A)
        np.testing.assert_array_equal(truth.q_segment_from_sensor, result.mounting[sensor_id].q_segment_from_sensor)
        np.testing.assert_array_equal(truth.gyr_bias_rad_s, result.truth.gyr_bias_rad_s[sensor_id])
    for column, values in result.truth.joint_angles_deg.items():
        np.testing.assert_array_equal(back.truth.joint_angles_deg[column], values)
    assert [(m.t_s, m.label) for m in back.markers] == result.markers


def test_empty_session_round_trip(tmp_path: Path) -> None:
    back = read_session(write_session(tmp_path / "empty.h5", Session()))
    assert back.sensors == {} and back.markers == [] and back.truth is None
    assert back.calibrations == {} and back.results == {}
    assert set(back.metadata) == {"created_utc", "mimucap_version"}


def _replace_dataset(path: Path, name: str, change) -> None:
    """Rewrite dataset ``name`` of the session at ``path`` with ``change(values)``."""
    with h5py.File(path, "a") as h5:
        values = change(h5[name][()].copy())
        del h5[name]
        h5[name] = values


def _set_rows(rows, value):
    def change(values):
        values[rows] = value
        return values
    return change


def _swap(values):
    values[[200, 201]] = values[[201, 200]]
    return values


@pytest.mark.parametrize("change, message", [
    (lambda t: np.where(np.arange(len(t)) >= 300, t - 2.0, t), r"goes back from 2\.990 s to 1\.000 s at row 300"),
    (_set_rows(151, 1.50), r"repeats 1\.500 s at row 151"),
    (_swap, r"goes back from 2\.010 s to 2\.000 s at row 201"),
    (_set_rows(99, np.nan), r"is NaN at row 99"),
    (_set_rows(480, np.inf), r"is \+inf at row 480"),
])
def test_time_stamps_must_be_finite_and_increasing(tmp_path: Path, change, message) -> None:
    path = write_session(tmp_path / "t.h5", _session(np.random.default_rng(3)))
    _replace_dataset(path, "sensors/S01/t_s", change)
    with pytest.raises(SessionFormatError, match=r"t\.h5: sensor S01: t_s " + message):
        read_session(path)


def test_a_gyroscope_in_degrees_per_second_is_refused(tmp_path: Path) -> None:
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.core.simulate.suit import simulate_session
    from mimucap.io.session import session_from_simulation

    result = simulate_session(SimulationConfig(scenario="walk", duration_s=4.0, n_sensors=10, seed=1))
    path = write_session(tmp_path / "dps.h5", session_from_simulation(result, include_truth=False))
    read_session(path)                                  # in rad/s the simulated walk reads
    gyr = result.samples["S03"].gyr
    _replace_dataset(path, "sensors/S03/gyr", np.rad2deg)
    row, axis = np.unravel_index(np.nanargmax(np.abs(gyr)), gyr.shape)
    peak = np.rad2deg(np.abs(gyr[row, axis]))
    with pytest.raises(SessionFormatError,
                       match=rf"dps\.h5: sensor S03: gyroscope reaches {peak:.4g} rad/s about its "
                             rf"{'xyz'[axis]} axis at row {row}, .*±70 rad/s ≈ ±4011 °/s.*is it in °/s\? "
                             rf"MimuCap expects rad/s"):
        read_session(path)


def test_the_gyroscope_bound_keeps_saturated_and_missing_samples(tmp_path: Path) -> None:
    """A ±2000 °/s sensor saturated on every axis is a rate in rad/s; NaN and infinite values are
    left to the filters (which skip and count them); only a value beyond the bound is refused."""
    saturated = np.full((3, 3), np.deg2rad(2000.0))
    assert gyro_range_problem(saturated) is None
    assert gyro_range_problem(np.array([[GYR_MAX_RAD_S, -GYR_MAX_RAD_S, np.nan], [np.inf, 0, -np.inf]])) is None
    assert "not a plausible rate" in gyro_range_problem(np.array([[0.0, 1e30, 0.0]]))
    path = write_session(tmp_path / "g.h5", _session(np.random.default_rng(4)))
    _replace_dataset(path, "sensors/S01/gyr", _set_rows(slice(10, 20), np.nan))
    _replace_dataset(path, "sensors/S01/gyr", _set_rows(30, np.inf))
    assert np.isnan(read_session(path).sensors["S01"].gyr[10:20]).all()
    _replace_dataset(path, "sensors/S01/gyr", _set_rows((77, 1), -71.0))
    with pytest.raises(SessionFormatError, match=r"sensor S01: gyroscope reaches 71 rad/s about its y axis at row 77"):
        read_session(path)
