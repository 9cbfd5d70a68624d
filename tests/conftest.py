"""Shared test helpers: where the real recordings live, and a per-test user data directory."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path:
    """``<repo>/../shared/data``: real recordings with their own licences (never copied in)."""
    path = (REPO_ROOT / ".." / "shared" / "data").resolve()
    if not path.is_dir():
        raise FileNotFoundError(f"shared data not found at {path}: the tests need ../shared beside the repository")
    return path


@pytest.fixture
def shared_data() -> Path:
    return shared_data_dir()


@pytest.fixture(autouse=True)
def _isolated_user_dirs(tmp_path_factory, monkeypatch):
    """Keep calibrations and settings written by tests out of the real user's folders."""
    base = tmp_path_factory.mktemp("user")
    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(base / "data"))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(base / "config"))
    monkeypatch.setenv("XDG_DATA_HOME", str(base / "share"))


def record_calibrated_session(path: Path, scenario: str = "walk", seconds: float = 8.0, seed: int = 3,
                              n_sensors: int = 10, markers: tuple = (), settle_s: float = 1.0) -> Path:
    """A session recorded as a clinician records one, on the simulated suit with its default
    sensor errors: magnetometer turns, N/T-pose body calibration (both stored in the session),
    then, ``settle_s`` after the subject went back to ``scenario`` (whose lead-in is a second of
    N-pose), ``seconds`` of it. Its truth is kept for evaluation only."""
    from mimucap.core.simulate.config import SimulationConfig
    from mimucap.io.calibration_store import CalibrationStore
    from mimucap.session.feeds import SimulatorFeed
    from mimucap.session.guided_session import SteppedClock, run_guided_session
    from mimucap.session.live import LiveSession

    clock = SteppedClock(10.0)
    config = SimulationConfig(scenario=scenario, seed=seed, n_sensors=n_sensors)
    live = LiveSession(SimulatorFeed(config, clock=clock), scenario, model_name=config.model_name,
                       height_m=config.height_m, clock=clock)
    live.start()
    run_guided_session(live, clock, path, seconds, CalibrationStore(path.parent / f"{path.stem}-store"),
                       markers=markers, settle_s=settle_s, subject={"id": "simulated", "height_m": config.height_m})
    return path


@pytest.fixture(scope="session")
def record_calibrated():
    """:func:`record_calibrated_session`, for tests that record their own."""
    return record_calibrated_session


@pytest.fixture(scope="session")
def calibrated_walk(tmp_path_factory) -> Path:
    """A calibrated recording of eight seconds of walking (see :func:`record_calibrated_session`),
    with markers at 2 s and 6 s; shared by the tests that read it (do not modify it)."""
    folder = tmp_path_factory.mktemp("calibrated")
    return record_calibrated_session(folder / "walk.h5", markers=((2.0, "start"), (6.0, "end")))
