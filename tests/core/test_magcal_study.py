"""The rotation-protocol study reproduces the seed's qualitative finding."""

from __future__ import annotations

import numpy as np
import pytest

from mimucap.core.magcal.study import (
    STUDY_PROTOCOLS, StudySettings, Trial, evaluate_protocols, format_tables, simulate_study,
)


@pytest.fixture(scope="module")
def study():
    return simulate_study(StudySettings(trials=4, seed=5))


def test_single_axis_once_beats_figure8_five_times(study) -> None:
    single, figure8 = study.result("single_axis-1"), study.result("figure8-5")
    assert single.centre_rmse_uT < figure8.centre_rmse_uT
    assert single.radii_rmse_uT < figure8.radii_rmse_uT
    # The seed's single-axis RMSE was 0.38-0.55 µT on a real MPU-9250: the simulated one is no worse.
    assert single.centre_rmse_uT < 0.55
    assert single.refused == 0 and single.verdicts[0] == single.trials


def test_every_protocol_has_its_trials_and_a_duration(study) -> None:
    assert [r.key for r in study.protocols] == [p.key for p in STUDY_PROTOCOLS]
    for result in study.protocols:
        assert result.trials == 4
        assert len(result.centres) + result.refused == 4
        assert result.duration_s > 0
    durations = [study.result(f"figure8-{n}").duration_s for n in range(1, 6)]
    assert durations == sorted(durations)


def test_tables_are_printed(study) -> None:
    text = format_tables(study)
    assert "Table 1: figure-8" in text and "Table 2: single-axis" in text
    assert text.count("centre_RMSE_uT") == 2
    rows = [line.split() for line in text.splitlines() if line.strip() and line.split()[0].isdigit()]
    assert len(rows) == 8
    single_once = rows[5]
    assert float(single_once[2]) == pytest.approx(study.result("single_axis-1").centre_rmse_uT, abs=5e-4)


def test_evaluate_protocols_measures_against_the_reference() -> None:
    rng = np.random.default_rng(0)
    u = rng.normal(size=(800, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    reference = 49.3 * u
    shifted = [Trial(49.3 * u + [0.3, 0.0, 0.0], 10.0), Trial(49.3 * u - [0.3, 0.0, 0.0], 12.0)]
    degenerate = [Trial(np.column_stack([np.cos(np.arange(100)), np.sin(np.arange(100)), np.zeros(100)]), 1.0)]
    result = evaluate_protocols({"shifted-1": shifted, "flat-1": degenerate}, reference)
    np.testing.assert_allclose(result.reference_centre_uT, 0.0, atol=1e-9)
    shifted_result = result.result("shifted-1")
    assert shifted_result.centre_rmse_uT == pytest.approx(0.3 / np.sqrt(3), rel=1e-6)
    assert shifted_result.radii_rmse_uT == pytest.approx(0.0, abs=1e-9)
    assert shifted_result.duration_s == 11.0
    flat = result.result("flat-1")
    assert flat.refused == 1 and np.isnan(flat.centre_rmse_uT)
    with pytest.raises(KeyError):
        result.result("figure8-9")
