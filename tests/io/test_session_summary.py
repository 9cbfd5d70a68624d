"""The summary of a session file (what the library lists), read without its samples."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from mimucap.io.session import SessionFormatError, read_session, read_summary, session_duration_s

from tests.library_sessions import make_session


def test_the_summary_tells_what_the_whole_file_tells(tmp_path: Path) -> None:
    path = make_session(tmp_path / "a.h5", "P001", 3.0, body_verdict="good", tags=("knee",))
    summary, session = read_summary(path), read_session(path)
    assert summary.metadata == session.metadata and summary.metadata["subject"]["id"] == "P001"
    assert summary.segments == {"S01": "pelvis", "S02": "thigh_r"} == session.sensor_segments()
    assert summary.duration_s == session_duration_s(session) == pytest.approx(3.001)
    assert summary.markers == session.markers and summary.calibrations == session.calibrations


def test_a_damaged_description_is_found_and_the_samples_are_left_to_the_whole_read(tmp_path: Path) -> None:
    path = make_session(tmp_path / "m.h5", "P001", 1.0)
    with h5py.File(path, "a") as h5:
        del h5["sensors/S01/t_s"]
    with pytest.raises(SessionFormatError, match=r"m\.h5: missing dataset /sensors/S01/t_s"):
        read_summary(path)
    path = make_session(tmp_path / "j.h5", "P001", 1.0, body_verdict="good")
    with h5py.File(path, "a") as h5:
        h5.attrs["metadata_json"] = "{not json"
    with pytest.raises(SessionFormatError, match=r"j\.h5: metadata_json is not valid JSON"):
        read_summary(path)
    truncated = tmp_path / "t.h5"
    truncated.write_bytes(path.read_bytes()[:2000])
    with pytest.raises(SessionFormatError, match=r"t\.h5"):
        read_summary(truncated)
    path = make_session(tmp_path / "v.h5", "P001", 1.0)
    with h5py.File(path, "a") as h5:
        h5["sensors/S01/t_s"][10] = np.nan  # a damaged time stamp inside the stream
        del h5["sensors/S02/gyr"]
        h5["sensors/S02/gyr"] = np.zeros((7, 3))
    assert read_summary(path).duration_s == pytest.approx(1.001)
    with pytest.raises(SessionFormatError, match="sensor S01|gyr"):
        read_session(path)
