"""Shared test helpers: where the real recordings live, and a per-test user data directory."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.external_data import DATA_SETS, DEFAULT_ROOT_TEXT, REPO_ROOT, data_required, data_root, is_present

#: The reason text of a test skipped for want of a data set starts with this.
MISSING_DATA = "needs the external data set"


def pytest_configure(config) -> None:
    config.addinivalue_line("markers", "data(*names): reads these external data sets (tests/external_data.py)")


def pytest_collection_modifyitems(config, items) -> None:
    """Skip (or, where the data are required, refuse to run) tests whose data set is missing."""
    missing_sets: dict[str, int] = {}
    for item in items:
        names = [name for marker in item.iter_markers("data") for name in marker.args]
        unknown = [name for name in names if name not in DATA_SETS]
        if unknown:
            raise pytest.UsageError(f"{item.nodeid}: unknown data set {', '.join(unknown)}")
        if "shared_data" in getattr(item, "fixturenames", ()) and not names:
            raise pytest.UsageError(f"{item.nodeid} reads external data: mark it with @pytest.mark.data(\"<set>\")")
        missing = [name for name in names if not is_present(name)]
        for name in missing:
            missing_sets[name] = missing_sets.get(name, 0) + 1
        if missing:
            titles = ", ".join(f"{DATA_SETS[n].title} ({n})" for n in missing)
            item.add_marker(pytest.mark.skip(reason=f"{MISSING_DATA}: {titles}, not found in {data_root()}"))
    if missing_sets and data_required():
        listed = "; ".join(f"{DATA_SETS[n].title}: {data_root() / DATA_SETS[n].folder} ({count} tests)"
                           for n, count in sorted(missing_sets.items()))
        raise pytest.UsageError(f"MIMUCAP_REQUIRE_TEST_DATA is set but data sets are missing: {listed}")


def _skip_reason(report) -> str:
    return report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)


def pytest_terminal_summary(terminalreporter, config) -> None:
    """Count the tests skipped for want of external recordings, per data set (said last)."""
    skipped = [report for report in terminalreporter.stats.get("skipped", [])
               if MISSING_DATA in _skip_reason(report)]
    counts = {name: sum(1 for report in skipped if f"({name})" in _skip_reason(report)) for name in DATA_SETS}
    listed = ", ".join(f"{DATA_SETS[n].title} {c}" for n, c in sorted(counts.items()) if c)
    config.stash[_DATA_LINE] = (
        f"{len(skipped)} tests skipped for want of external recordings ({listed}); put the data sets in "
        f"MIMUCAP_TEST_DATA (default {DEFAULT_ROOT_TEXT}; README, 'Test data')") if skipped else ""


def pytest_unconfigure(config) -> None:
    """The data line is the run's last line, after pytest's own counts."""
    line = config.stash.get(_DATA_LINE, "")
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    if line and reporter is not None:
        reporter.write_line(line)


_DATA_LINE = pytest.StashKey[str]()


@pytest.fixture
def shared_data() -> Path:
    """The external data root (tests that use it carry ``@pytest.mark.data``)."""
    return data_root()


@pytest.fixture(autouse=True)
def _isolated_user_dirs(tmp_path_factory, monkeypatch):
    """Keep calibrations and settings written by tests out of the real user's folders."""
    base = tmp_path_factory.mktemp("user")
    monkeypatch.setenv("MIMUCAP_DATA_DIR", str(base / "data"))
    monkeypatch.setenv("XDG_CONFIG_HOME", str(base / "config"))
    monkeypatch.setenv("XDG_DATA_HOME", str(base / "share"))
    monkeypatch.setenv("XDG_STATE_HOME", str(base / "state"))


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
