"""The PDF report: rendered from an analysed simulated session (gait, curves, ROM markers),
turned into page pictures with pdftoppm (poppler-utils), and checked for content; the
comparison report and the command line too."""

from __future__ import annotations

import re
import shutil
import subprocess
import unicodedata

import numpy as np
import pytest
from PyQt5.QtGui import QImage

from mimucap.cli import main
from mimucap.core.simulate.config import SimulationConfig
from mimucap.gui.pdf_report import write_comparison_report, write_report
from mimucap.io.normative_bands import read_normative_bands
from mimucap.session.recorded.gait_validation import simulated_analysis

ROM_MARKERS = (
    (30.0, "rom:knee_flexion:left:start"), (37.0, "rom:knee_flexion:left:end"),
    (37.2, "rom:shoulder_flexion:right:start"), (44.9, "rom:shoulder_flexion:right:end"),
)
BAND = """# mimucap-normative-bands 1
# source: hand-made test band for the report test, no real subjects
joint,axis,percent,lower_deg,upper_deg
knee,flexion,0,0,10
knee,flexion,70,50,70
knee,flexion,100,0,10
"""


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    folder = tmp_path_factory.mktemp("report")
    config = SimulationConfig(scenario="demo", duration_s=45.0, n_sensors=10, errors="bno055", seed=3)
    _, analysis = simulated_analysis(config, folder, ROM_MARKERS)
    return analysis


def pages_as_images(pdf, folder):
    if shutil.which("pdftoppm") is None:
        pytest.fail("pdftoppm (Debian poppler-utils) is needed: make debs installs it")
    subprocess.run(["pdftoppm", "-r", "50", "-png", str(pdf), str(folder / "page")], check=True)
    return [QImage(str(p)) for p in sorted(folder.glob("page-*.png"))]


def ink(image: QImage) -> float:
    """Share of pixels that are not white."""
    ptr = image.convertToFormat(QImage.Format_Grayscale8)
    data = np.frombuffer(ptr.constBits().asstring(ptr.sizeInBytes()), dtype=np.uint8).reshape(ptr.height(), ptr.bytesPerLine())
    return float(np.mean(data[:, :ptr.width()] < 200))


def test_report_renders_every_section(qapp, analysed, tmp_path):
    band_path = tmp_path / "band.csv"
    band_path.write_text(BAND)
    pdf = write_report(tmp_path / "report.pdf", analysed, read_normative_bands(band_path), notes="Follow-up in 6 weeks.")
    text = pdf.read_bytes()
    assert text.startswith(b"%PDF")
    images = pages_as_images(pdf, tmp_path)
    assert len(images) >= 2
    assert all(ink(image) > 0.01 for image in images)
    # The analysis behind the pages: gait parameters, curves of every joint, both ROM movements.
    assert analysed.gait is not None and len(analysed.gait.analysed) >= 20
    assert {"knee_l_flexion_deg", "knee_r_flexion_deg", "lumbar_flexion_deg@left"} <= set(analysed.curves)
    assert set(analysed.rom) == {("knee_flexion", "left"), ("shoulder_flexion", "right")}
    assert analysed.rom[("knee_flexion", "left")].repetitions == 2
    # In the words a clinician reads: ROM markers, the skeleton, the calibrations' quality
    words = unicodedata.normalize("NFKC", subprocess.run(["pdftotext", str(pdf), "-"], check=True,
                                                         capture_output=True, text=True).stdout)  # "ﬂ" → "fl"
    assert "Knee flexion (left) — start" in words and "rom:knee_flexion" not in words
    assert "10-segment skeleton" in words and "ten_segment" not in words
    assert "verdict" not in words and not re.search(r"\d{4}-\d\d-\d\dT\d\d:", words)  # no ISO times


def test_comparison_report_and_command_line(qapp, analysed, tmp_path):
    pdf = write_comparison_report(tmp_path / "compare.pdf", analysed, analysed)
    assert len(pages_as_images(pdf, tmp_path)) >= 2
    session = analysed.review.path
    out = tmp_path / "cli.pdf"
    assert main(["report", str(session), "--out", str(out), "--before", str(session), "--csv", str(tmp_path / "csv")]) == 0
    assert out.read_bytes().startswith(b"%PDF")
    assert (tmp_path / "csv" / "rom.csv").is_file() and (tmp_path / "csv" / "parameters.csv").is_file()
    assert main(["report", str(session), "--out", str(tmp_path / "r.txt")]) == 1


def test_the_report_lists_the_doubtful_joints_with_when_and_why(qapp, analysed, tmp_path):
    """In the demo's T-pose the shoulders are abducted to about 90°, where Z-X'-Y'' is singular:
    their angles are marked doubtful there; the walking knees are not."""
    rows = {row.joint: row for row in analysed.doubt}
    assert set(rows) == {"shoulder_l", "shoulder_r"}
    joint, _percent, when, why = rows["shoulder_r"].cells()
    assert joint == "Right shoulder" and "gimbal lock" in why
    start, end = (float(v) for v in when.split("–"))
    assert 3.0 < start < end < 7.0  # the T-pose of the demo: 3-6 s
    assert not any(analysed.curve_doubt.values()) and not any(analysed.rom_doubt.values())
    pdf = write_report(tmp_path / "report.pdf", analysed)
    if shutil.which("pdftotext") is None:
        pytest.fail("pdftotext (Debian poppler-utils) is needed: make debs installs it")
    text = subprocess.run(["pdftotext", str(pdf), "-"], check=True, capture_output=True, text=True).stdout
    assert "Doubtful data" in text and "Right shoulder:" in text and "gimbal lock" in text
