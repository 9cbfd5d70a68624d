"""Heading from the body on the README's command-line route (simulate → magcal fit --save →
bodycal → angles), in a field changed alike for the whole body (issue 34's uniform disturbance)
and in the clinic room, against the simulator's truth stored in the session (no command reads
it). The seeds (7 and 8) are among those the shared field's weighting was looked at with (3, 5,
7 and 8); README, *Rooms*, gives seed 11, held back. The N-pose headings' turn toward the
reprocessed tracks was looked at with seeds 3 and 11 only (README, *Rooms*)."""

from __future__ import annotations

import re

import pytest

from mimucap.cli import main
from mimucap.core import phase_markers
from mimucap.io.angles_export import read_angles_csv
from mimucap.io.session import read_session
from mimucap.session.angle_accuracy import pooled_rms_deg

COLUMNS = tuple(f"{joint}_{side}_{axis}_deg" for joint in ("hip", "knee") for side in ("l", "r")
                for axis in ("flexion", "adduction", "rotation"))
UNIFORM_DISTURBANCE = "30,-20,10,34,90"


def walking_rms(session, table) -> dict[str, float]:
    """RMS error (deg) per knee and hip column over the walking phases (1 s after each start)."""
    recorded = read_session(session)
    spans = [(start + 1.0, stop) for start, stop in phase_markers.phase_windows(recorded.markers, phase_markers.WALK,
                                                                                 float(table.t_s[-1]))]
    return pooled_rms_deg(table.t_s, table.angles_deg, recorded.truth.t_s, recorded.truth.joint_angles_deg, spans,
                          COLUMNS)


@pytest.fixture(scope="module", params=[("uniform", 7), ("clinic", 8)], ids=["uniform-seed7", "clinic-seed8"])
def disturbed_route(request, tmp_path_factory):
    condition, seed = request.param
    folder = tmp_path_factory.mktemp(f"{condition}{seed}")
    session = folder / "demo.h5"
    extra = ["--disturbance", UNIFORM_DISTURBANCE] if condition == "uniform" else ["--room", "clinic"]
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("MIMUCAP_DATA_DIR", str(folder / "data"))
        assert main(["simulate", "--scenario", "demo", "--duration", "90", "--seed", str(seed), "--out", str(session)]
                    + extra) == 0
        assert main(["magcal", "fit", str(session), "--save"]) == 0
        calibration = folder / "CAL.json"
        assert main(["bodycal", str(session), "--out", str(calibration), "--accept-poor"]) == 0
        results = {}
        for kind, options in (("reprocessed", []), ("live", ["--live"]),
                              ("reprocessed-magnetometer", ["--heading", "magnetometer"])):
            out = folder / f"{kind}.csv"
            assert main(["angles", str(session), "--calibration", str(calibration), "--out", str(out)] + options) == 0
            results[kind] = (walking_rms(session, read_angles_csv(out)), out.read_text().splitlines()[:60])
    return condition, results


@pytest.mark.parametrize("kind, flexion_deg, other_deg", [("reprocessed", 2.0, 4.0), ("live", 3.0, 6.0)])
def test_knee_angles_hold_in_a_disturbed_field(disturbed_route, kind, flexion_deg, other_deg):
    condition, results = disturbed_route
    rms, _header = results[kind]
    for column, value in rms.items():
        if column.startswith("knee") or column.endswith("flexion_deg"):
            limit = flexion_deg if column.endswith("flexion_deg") else other_deg
            assert value <= limit, f"{condition} {kind}: {column} {value:.1f}° RMS (≤ {limit}° asked)"


def test_the_hip_columns_hold_too(disturbed_route):
    """Every hip column meets the issue's limits, in the clinic room too, where the field at the
    thighs turns as they walk through it without a change of magnitude or dip a check could see
    (its relative errors count with the inverse of their variance)."""
    condition, results = disturbed_route
    for kind, other_deg in (("reprocessed", 4.0), ("live", 6.0)):
        rms, _header = results[kind]
        for column, value in rms.items():
            if column.startswith("hip") and not column.endswith("flexion_deg"):
                assert value <= other_deg, f"{condition} {kind}: {column} {value:.1f}° RMS (≤ {other_deg}°)"


def test_the_columns_outside_flexion_hold_within_half_the_limits(disturbed_route):
    """Every knee and hip column that is not a flexion holds within half the issue's limits. In
    the clinic this needs the N-pose headings turned toward the reprocessed tracks where a
    sensor's field varied over its path: the floor's field turns the thighs' field at the N-pose's
    place by degrees, with no change of magnitude or dip, and taken as it is that turn stayed in
    every hip's axial rotation for the whole walk (seed 8: 2.8° reprocessed, 3.5° live on the
    right hip; knee adduction 1.8°)."""
    condition, results = disturbed_route
    for kind, other_deg in (("reprocessed", 2.0), ("live", 3.0)):
        rms, _header = results[kind]
        for column, value in rms.items():
            if not column.endswith("flexion_deg"):
                assert value <= other_deg, f"{condition} {kind}: {column} {value:.1f}° RMS (≤ {other_deg}°)"


def test_the_coupling_beats_each_sensor_on_its_own_magnetometer(disturbed_route):
    _condition, results = disturbed_route
    coupled, single = results["reprocessed"][0], results["reprocessed-magnetometer"][0]
    knees = [c for c in COLUMNS if c.startswith("knee")]
    assert sum(coupled[c] for c in knees) < 0.6 * sum(single[c] for c in knees)


def test_the_file_says_where_the_headings_came_from(disturbed_route):
    _condition, results = disturbed_route
    header = "\n".join(results["reprocessed"][1])
    assert "Headings: relative headings from the field the body shares" in header
    # the shanks, through their knees, from when they were strapped on (the first 26 s of the
    # demo turn the sensors off the body for their magnetometer calibration: no hinge there)
    coupled = re.findall(r"; ([^;:]+): [^;]*joint (\d+) %", header)
    assert sorted(s.strip() for sensors, _share in coupled for s in sensors.split(",")) == ["S09", "S10"], coupled
    assert min(int(share) for _sensors, share in coupled) >= 65, coupled
    single = "\n".join(results["reprocessed-magnetometer"][1])
    assert "each sensor's heading from its own magnetometer" in single
