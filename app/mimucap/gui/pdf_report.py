"""The clinical PDF report, drawn with Qt's own PDF writer (``QPdfWriter`` and ``QPainter``: no
further dependency). Needs a ``QGuiApplication`` (the command line makes one on the offscreen
platform).

A report of one session (:func:`write_report`): subject id, recording date and length, what
the report holds (result, body and magnetometer calibrations, model, software, file: the
record every output carries, :mod:`mimucap.session.recorded.provenance`), sensors, the doubtful data
(which joints' angles may be wrong, when and why), the gait table beside typical adult values,
the gait-cycle curves of every joint angle (left and right mean ± SD, stance/swing boundary, a
normative band where one is given; a curve whose strides hold doubtful samples says how many,
in orange), the ROM table beside the reference values (a movement recorded while doubtful is
named under it), the markers and the notes, and for a recording of a guided clinical test
its result beside the reference with the subject's earlier visits (:func:`clinical_test_section`;
alone: :func:`write_clinical_test_report`).
A comparison report (:func:`write_comparison_report`) puts two sessions of one subject
(before / after) side by side with the differences.

What it shows comes from :class:`mimucap.session.recorded.analysis.SessionAnalysis` only; pages are
A4 portrait at 150 dpi.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from PyQt5.QtCore import QMarginsF, QPointF, QRectF, Qt
from PyQt5.QtGui import QColor, QFont, QPageLayout, QPageSize, QPainter, QPdfWriter, QPen, QPolygonF

from mimucap.core.analysis.gait_cycle import CYCLE_PERCENT, NormativeBand
from mimucap.core.analysis import rom as rom_core
from mimucap.core.clinical_names import segment_name
from mimucap.core.wording import plural
from mimucap.session.recorded.analysis import (
    GAIT_PARAMETER_HEADER,
    ROM_HEADER,
    TYPICAL_SOURCE,
    SessionAnalysis,
    body_calibration_of,
    curve_doubt_of,
    curve_groups,
    format_value,
    gait_parameter_rows,
    rom_rows,
)
from mimucap.session.views.calibration_age import local_time_text
from mimucap.session.views.plot_scaling import nice_ticks

DPI = 150
#: The height (pixels at :data:`DPI`) of one row of gait-cycle curves: their heading starts a
#: page only when the legend and one row do not fit on the current one.
CURVE_ROW_PX = 250.0
LEFT_COLOUR = QColor(30, 100, 200)
RIGHT_COLOUR = QColor(200, 50, 40)
#: The colour of what is doubtful.
DOUBT_COLOUR = QColor(200, 100, 0)


def _numeric(text: str) -> bool:
    head = text.split(" ")[0].replace("–", "").replace("−", "-")
    try:
        float(head)
        return True
    except ValueError:
        return text.strip() in ("–", "")


class _Document:
    """A paginated drawing surface: a cursor ``y`` (pixels) moving down A4 pages."""

    def __init__(self, path: Path, title: str) -> None:
        self.writer = QPdfWriter(str(path))
        self.writer.setResolution(DPI)
        self.writer.setPageLayout(QPageLayout(QPageSize(QPageSize.A4), QPageLayout.Portrait, QMarginsF(15, 15, 15, 15)))
        self.writer.setTitle(title)
        self.writer.setCreator("MimuCap")
        self.painter = QPainter(self.writer)
        rect = self.writer.pageLayout().paintRectPixels(DPI)
        self.width, self.height = rect.width(), rect.height()
        self.y = 0.0
        self.page = 1

    def font(self, size: float, bold: bool = False) -> None:
        font = QFont("DejaVu Sans")
        font.setPointSizeF(size)
        font.setBold(bold)
        self.painter.setFont(font)

    def need(self, height: float) -> None:
        if self.y + height > self.height - 30:
            self.new_page()

    def new_page(self) -> None:
        self.writer.newPage()
        self.page += 1
        self.y = 0.0

    def text(self, text: str, size: float = 9.0, bold: bool = False, gap: float = 4.0,
             colour: QColor | None = None) -> None:
        self.font(size, bold)
        metrics = self.painter.fontMetrics()
        rect = metrics.boundingRect(0, 0, int(self.width), 10000, int(Qt.TextWordWrap), text)
        self.need(rect.height() + gap)
        self.painter.setPen(colour or QColor(0, 0, 0))
        self.painter.drawText(QRectF(0, self.y, self.width, rect.height() + 2), int(Qt.TextWordWrap), text)
        self.y += rect.height() + gap

    def heading(self, text: str, keep_px: float = 0.0) -> None:
        """A section's heading, kept on one page with what follows it: at least three lines of
        body text, or ``keep_px`` (pixels) when more must follow it (a figure)."""
        self.font(9.0)
        body = 3 * self.painter.fontMetrics().height()
        self.font(11.0, True)
        self.need(self.painter.fontMetrics().height() + 4 + max(body, keep_px))
        self.text(text, 11, True, gap=4)

    def table(self, header: Sequence[str], rows: Sequence[Sequence[str]], widths: Sequence[float],
              size: float = 8.0) -> None:
        """A table; ``widths`` fractions of the page width."""
        self.font(size)
        line = self.painter.fontMetrics().height() + 6
        xs = [0.0]
        for w in widths:
            xs.append(xs[-1] + w * self.width)

        right = [k > 0 and bool(rows) and all(_numeric(str(r[k])) for r in rows) for k in range(len(header))]

        def draw_row(cells, bold, shade):
            self.need(line)
            if shade:
                self.painter.fillRect(QRectF(0, self.y, xs[-1], line), QColor(238, 241, 246))
            self.font(size, bold)
            self.painter.setPen(QColor(0, 0, 0))
            for k, cell in enumerate(cells):
                align = int(Qt.AlignVCenter | (Qt.AlignRight if right[k] else Qt.AlignLeft))
                self.painter.drawText(QRectF(xs[k] + 3, self.y, xs[k + 1] - xs[k] - 6, line), align, str(cell))
            self.y += line

        draw_row(header, True, False)
        self.painter.setPen(QPen(QColor(80, 80, 80), 1))
        self.painter.drawLine(QPointF(0, self.y), QPointF(xs[-1], self.y))
        for index, row in enumerate(rows):
            draw_row(row, False, index % 2 == 1)
        self.y += 8

    def finish(self) -> None:
        self.painter.end()


def _plot(doc: _Document, rect: QRectF, title: str, curves: list[tuple[object, QColor, Qt.PenStyle]],
          band: NormativeBand | None, boundaries: list[tuple[float, QColor]], doubtful: str = "") -> None:
    """One gait-cycle plot: x 0-100 %, y degrees; each curve a CycleCurve drawn mean ± SD;
    ``doubtful`` says (in orange, under the title) which of its strides hold doubtful samples."""
    p = doc.painter
    values = []
    for curve, _, _ in curves:
        values += list(curve.mean_deg - curve.sd_deg) + list(curve.mean_deg + curve.sd_deg)
    if band is not None:
        low, high = band.on_cycle()
        values += list(low) + list(high)
    finite = [v for v in values if math.isfinite(v)]
    lo, hi = (min(finite), max(finite)) if finite else (-1.0, 1.0)
    if hi - lo < 5.0:
        mid = 0.5 * (hi + lo)
        lo, hi = mid - 2.5, mid + 2.5
    pad = 0.08 * (hi - lo)
    lo, hi = lo - pad, hi + pad
    doc.font(7.5, True)
    p.setPen(QColor(0, 0, 0))
    p.drawText(QRectF(rect.left(), rect.top(), rect.width(), 18), int(Qt.AlignLeft | Qt.AlignVCenter), title)
    top = 20.0
    if doubtful:
        doc.font(6.5)
        p.setPen(DOUBT_COLOUR)
        p.drawText(QRectF(rect.left(), rect.top() + 16, rect.width(), 14), int(Qt.AlignLeft | Qt.AlignVCenter), doubtful)
        top = 32.0
    area = QRectF(rect.left() + 42, rect.top() + top, rect.width() - 48, rect.height() - top - 22)
    x_of = lambda pct: area.left() + pct / 100.0 * area.width()  # noqa: E731
    y_of = lambda deg: area.bottom() - (deg - lo) / (hi - lo) * area.height()  # noqa: E731
    p.setPen(QPen(QColor(150, 150, 150), 1))
    p.drawRect(area)
    doc.font(6.5)
    p.setPen(QColor(60, 60, 60))
    for deg, _label in nice_ticks(lo, hi, wanted=6):  # 3 to 6 round values
        p.drawText(QRectF(rect.left(), y_of(deg) - 8, 40, 16), int(Qt.AlignRight | Qt.AlignVCenter),
                   f"{deg:g}°".replace("-0°", "0°"))
        p.setPen(QPen(QColor(225, 225, 225), 1))
        p.drawLine(QPointF(area.left(), y_of(deg)), QPointF(area.left() + 4, y_of(deg)))
        p.setPen(QColor(60, 60, 60))
    for pct in (0, 50, 100):
        p.drawText(QRectF(x_of(pct) - 20, area.bottom() + 2, 40, 14), int(Qt.AlignCenter), f"{pct}%")
    if lo < 0 < hi:
        p.setPen(QPen(QColor(200, 200, 200), 1, Qt.DotLine))
        p.drawLine(QPointF(area.left(), y_of(0)), QPointF(area.right(), y_of(0)))
    if band is not None:
        low, high = band.on_cycle()
        polygon = QPolygonF([QPointF(x_of(x), y_of(v)) for x, v in zip(CYCLE_PERCENT, high)]
                            + [QPointF(x_of(x), y_of(v)) for x, v in zip(CYCLE_PERCENT[::-1], low[::-1])])
        p.setPen(Qt.NoPen)
        p.setBrush(QColor(160, 160, 160, 90))
        p.drawPolygon(polygon)
        p.setBrush(Qt.NoBrush)
    for pct, colour in boundaries:
        if math.isfinite(pct):
            p.setPen(QPen(colour, 1.2, Qt.DashLine))
            p.drawLine(QPointF(x_of(pct), area.top()), QPointF(x_of(pct), area.bottom()))
    for curve, colour, style in curves:
        shade = QColor(colour)
        shade.setAlpha(45)
        upper, lower = curve.mean_deg + curve.sd_deg, curve.mean_deg - curve.sd_deg
        polygon = QPolygonF([QPointF(x_of(x), y_of(v)) for x, v in zip(CYCLE_PERCENT, upper)]
                            + [QPointF(x_of(x), y_of(v)) for x, v in zip(CYCLE_PERCENT[::-1], lower[::-1])])
        p.setPen(Qt.NoPen)
        p.setBrush(shade)
        p.drawPolygon(polygon)
        p.setBrush(Qt.NoBrush)
        p.setPen(QPen(colour, 2.0, style))
        p.drawPolyline(QPolygonF([QPointF(x_of(x), y_of(v)) for x, v in zip(CYCLE_PERCENT, curve.mean_deg)]))


def _curve_pages(doc: _Document, analyses: Sequence[SessionAnalysis], bands: dict[tuple[str, str], NormativeBand],
                 labels: Sequence[str]) -> None:
    groups = curve_groups(analyses)
    if not groups:
        doc.text("No gait-cycle curves (no straight-walking stride).", 9)
        return
    columns, plot_h = 3, CURVE_ROW_PX
    plot_w = doc.width / columns
    styles = [Qt.DashLine, Qt.SolidLine] if len(analyses) == 2 else [Qt.SolidLine]
    legend = "Left blue, right red: mean ± SD over the analysed strides; dashed vertical: stance/swing boundary"
    if len(analyses) == 2:
        legend = (f"Left blue, right red; {labels[0]} dashed, {labels[1]} solid; mean ± SD over the analysed "
                  f"strides; vertical lines: stance/swing boundary")
    if bands:
        legend += "; grey: normative band (" + "; ".join(sorted({b.source for b in bands.values()})) + ")"
    doc.text(legend, 7.5, gap=6, colour=QColor(70, 70, 70))
    for index, group in enumerate(groups):
        column = index % columns
        if column == 0:
            doc.need(plot_h)
        rect = QRectF(column * plot_w, doc.y, plot_w - 10, plot_h - 10)
        curves, boundaries, doubtful = [], [], []
        for analysis, label, by_side, style in zip(analyses, labels, group.curves, styles):
            for side, colour in (("left", LEFT_COLOUR), ("right", RIGHT_COLOUR)):
                curve = by_side.get(side)
                if curve is not None:
                    curves.append((curve, colour, style))
                    boundaries.append((curve.stance_percent, colour))
                    count = curve_doubt_of(analysis, curve)
                    if count:
                        where = f"{label} " if len(analyses) > 1 else ""
                        doubtful.append(f"{where}{side} {count}/{curve.n_strides}")
        note = ("doubtful strides: " + ", ".join(doubtful)) if doubtful else ""
        _plot(doc, rect, f"{group.label} (°)", curves, bands.get((group.joint, group.axis)), boundaries, note)
        if column == columns - 1 or index == len(groups) - 1:
            doc.y += plot_h


def _header(doc: _Document, analysis: SessionAnalysis, title: str) -> None:
    """Title, the subject (id, height, dominant side, age, sex, weight as recorded), the session
    (local date and time, length, condition, trial, file)."""
    review = analysis.review
    meta = review.session.metadata
    subject = dict(meta.get("subject") or {})
    doc.text(title, 16, True, gap=8)
    line = _subject_line(subject)
    if subject.get("dominance"):
        line += f", {subject['dominance']}-side dominant"
    doc.text(line, 10, gap=2)
    library = meta.get("library") or {}
    created = local_time_text(str(meta.get("created_utc") or ""))
    duration = review.end_s - review.start_s
    session = [f"Recorded {created}", f"length {duration:.1f} s"]
    if library.get("condition"):
        session.append(f"condition: {library['condition']}")
    if library.get("trial"):
        session.append(f"trial {library['trial']}")
    session.append(f"file {review.path.name}")
    doc.text(", ".join(session), 9)


def _sensors_section(doc: _Document, analysis: SessionAnalysis) -> None:
    """What the report holds (:attr:`~mimucap.session.recorded.review.ReviewData.provenance`, as every
    file says it), the sensors and the body calibration's remarks."""
    review = analysis.review
    session = review.session
    doc.heading("What this report holds")
    for label, text in review.provenance.items():
        doc.text(f"{label}: {text}.", 8, gap=2)
    for note in review.missing:
        doc.text(f"Note: {note}.", 8, gap=2)
    doc.heading("Sensors")
    sensors = ", ".join(f"{sid} ({segment_name(s.segment) if s.segment else 'not worn'})"
                        for sid, s in session.sensors.items())
    doc.text(f"{plural(len(session.sensors), 'sensor')}: {sensors}", 8)
    calibration = body_calibration_of(review)
    if calibration is not None:
        doc.text("Body calibration remarks: " + ("; ".join(calibration.quality.problems) or "none") + ".", 8)
    doc.text(f"Poses from: {review.pose_source}.", 8, gap=8)


def check_reportable(analysis: SessionAnalysis) -> None:
    """``ValueError`` when ``analysis`` lacks what a report needs (a body calibration)."""
    if not analysis.calibrated:
        raise ValueError(f"{analysis.review.path.name}: no report: {analysis.limits}")
def _doubt_section(doc: _Document, analysis: SessionAnalysis, label: str = "") -> None:
    """Which joints' angles may be wrong, when and why (:mod:`mimucap.core.pipeline.doubt_reasons`), or that none is."""
    doc.heading(f"Doubtful data{f' ({label})' if label else ''}")
    if not analysis.doubt:
        doc.text("Every joint angle passed MimuCap's checks (sensor orientations, field, lost samples, "
                 "body calibration): none is marked doubtful.", 8, gap=8)
        return
    doc.text("The joint angles below may be wrong where marked; the numbers of this report include them "
             "(a curve or movement that uses doubtful samples says so).", 8, colour=DOUBT_COLOUR)
    for row in analysis.doubt:
        joint, percent, when, why = row.cells()
        doc.text(f"{joint}: {percent} % of the recording ({when} s): {why}.", 7.5, gap=2)
    doc.y += 6


def _gait_section(doc: _Document, analysis: SessionAnalysis) -> None:
    doc.heading("Gait")
    gait = analysis.gait
    if gait is None or not gait.analysed:
        doc.text(f"No gait analysis: {analysis.gait_problem or 'no straight-walking stride'}.", 9, gap=8)
        return
    refused = [s for s in gait.strides if not s.analysed]
    n = {side: sum(1 for s in gait.analysed if s.side == side) for side in ("left", "right")}
    doc.text(f"{plural(len(gait.analysed), 'straight stride')} analysed (left {n['left']}, right {n['right']}), "
             f"{len(refused)} refused, {plural(len(gait.bouts), 'walking bout')}, {plural(len(gait.turns), 'turn')}. "
             + " ".join(f"{side.capitalize()}: {source}." for side, source in gait.sources.items()), 8)
    doc.table(GAIT_PARAMETER_HEADER, [row.cells() for row in gait_parameter_rows(gait)],
              [0.22, 0.14, 0.14, 0.14, 0.08, 0.11, 0.12])
    if refused:
        reasons: dict[str, int] = {}
        for s in refused:
            reasons[s.refused_because.split(":")[0]] = reasons.get(s.refused_because.split(":")[0], 0) + 1
        doc.text("Refused strides: " + "; ".join(f"{count} × {reason}" for reason, count in reasons.items())
                 + f". Symmetry: 100·|L−R|/mean(L,R) (Robinson et al. 1987). {TYPICAL_SOURCE}.", 7.5,
                 colour=QColor(70, 70, 70), gap=8)


def _rom_section(doc: _Document, analysis: SessionAnalysis) -> None:
    doc.heading("Range of motion")
    if not analysis.rom:
        doc.text("No ROM protocol in this recording.", 9, gap=8)
        return
    doc.table(ROM_HEADER, [row.cells() for row in rom_rows(analysis.rom)],
              [0.15, 0.06, 0.12, 0.13, 0.09, 0.1, 0.1, 0.12, 0.13])
    doubtful = [f"{rom_core.movement(key).label} ({side}): {100.0 * share:.0f} % of its window"
                for (key, side), share in analysis.rom_doubt.items() if share > 0 and (key, side) in analysis.rom]
    if doubtful:
        doc.text("Recorded while doubtful: " + "; ".join(doubtful) + ".", 7.5, colour=DOUBT_COLOUR)
    doc.text(f"Reference: active ROM of healthy adults, {rom_core.REFERENCE_SOURCE}. Shoulder: humeral elevation in the plane of the movement.",
             7.5, colour=QColor(70, 70, 70), gap=8)


def _markers_and_notes(doc: _Document, analysis: SessionAnalysis, notes: str) -> None:
    doc.heading("Markers")
    markers = analysis.review.markers
    if markers:
        doc.table(["Time (s)", "Label"], [[f"{m.t_s:.2f}", rom_core.marker_words(m.label)] for m in markers], [0.15, 0.6])
    else:
        doc.text("No markers.", 9, gap=8)
    subject_notes = ((analysis.review.session.metadata.get("subject") or {}).get("notes") or "").strip()
    doc.heading("Notes")
    doc.text("\n".join(t for t in (subject_notes, notes.strip()) if t) or "None.", 9, gap=8)


def write_report(path: str | Path, analysis: SessionAnalysis, bands: dict[tuple[str, str], NormativeBand] | None = None,
                 notes: str = "") -> Path:
    """Write the report of one session to ``path`` (PDF); returns the path. ``ValueError``
    for an analysis without a body calibration (:func:`check_reportable`)."""
    check_reportable(analysis)
    target = Path(path)
    doc = _Document(target, "MimuCap clinical report")
    try:
        _header(doc, analysis, "MimuCap clinical report")
        _sensors_section(doc, analysis)
        _doubt_section(doc, analysis)
        _gait_section(doc, analysis)
        _rom_section(doc, analysis)
        _markers_and_notes(doc, analysis, notes)
        _guided_test_page(doc, analysis)
        doc.heading("Joint angles over the gait cycle", keep_px=CURVE_ROW_PX)
        _curve_pages(doc, [analysis], bands or {}, ["session"])
    finally:
        doc.finish()
    return target


def write_comparison_report(path: str | Path, before: SessionAnalysis, after: SessionAnalysis,
                            bands: dict[tuple[str, str], NormativeBand] | None = None, notes: str = "") -> Path:
    """Write a before/after report of two sessions to ``path`` (PDF); returns the path.
    ``ValueError`` when either analysis lacks a body calibration or the two hold different
    results (as seen live / reprocessed)."""
    for analysis in (before, after):
        check_reportable(analysis)
    if before.review.result != after.review.result:
        raise ValueError(f"{before.review.path.name} is {before.review.result_label}, {after.review.path.name} "
                         f"{after.review.result_label}: compare results of one kind")
    target = Path(path)
    doc = _Document(target, "MimuCap comparison report")
    labels = (f"before ({before.review.path.name})", f"after ({after.review.path.name})")
    try:
        _header(doc, after, "MimuCap comparison report")
        doc.text(f"Before: {before.review.path.name}, recorded "
                 f"{local_time_text(str(before.review.session.metadata.get('created_utc') or ''))}. "
                 f"After: {after.review.path.name}, recorded "
                 f"{local_time_text(str(after.review.session.metadata.get('created_utc') or ''))}.", 9)
        for label, analysis in (("Before", before), ("After", after)):
            doc.text(f"What the {label.lower()} session's figures hold", 10, True, gap=3)
            for item, text in analysis.review.provenance.items():
                doc.text(f"{item}: {text}.", 7.5, gap=1)
        ids = {str(((a.review.session.metadata.get('subject') or {}).get('id')) or '') for a in (before, after)}
        if len(ids) > 1:
            doc.text(f"Warning: the two sessions name different subjects ({', '.join(sorted(ids))}).", 9, True,
                     colour=QColor(180, 0, 0))
        for label, analysis in zip(labels, (before, after)):
            _doubt_section(doc, analysis, label)
        doc.heading("Gait")
        if before.gait is None or after.gait is None:
            doc.text("Gait comparison not possible: "
                     + "; ".join(f"{label}: {a.gait_problem}" for label, a in zip(labels, (before, after)) if a.gait is None), 9)
        else:
            rows = []
            for b_row, a_row in zip(gait_parameter_rows(before.gait), gait_parameter_rows(after.gait)):
                d = a_row.digits
                for index, (b, a) in enumerate(zip(b_row.summaries, a_row.summaries)):
                    rows.append([a_row.title if index == 0 else "", a.side, format_value(b.mean, d),
                                 format_value(a.mean, d), format_value(a.mean - b.mean, d)])
            doc.table(["Parameter", "Side", "Before", "After", "After − before"], rows, [0.3, 0.1, 0.16, 0.16, 0.18])
        doc.heading("Range of motion (active ROM, degrees)")
        keys = list(dict.fromkeys(list(before.rom) + list(after.rom)))
        if keys:
            rows = []
            for key, side in keys:
                b = before.rom.get((key, side))
                a = after.rom.get((key, side))
                bv = b.active_rom_deg if b else math.nan
                av = a.active_rom_deg if a else math.nan
                rows.append([rom_core.movement(key).label, side, format_value(bv, 1), format_value(av, 1), format_value(av - bv, 1),
                             format_value(rom_core.movement(key).reference_deg, 0)])
            doc.table(["Movement", "Side", "Before", "After", "After − before", "Reference"], rows,
                      [0.26, 0.1, 0.14, 0.14, 0.18, 0.14])
        else:
            doc.text("No ROM protocol in either session.", 9, gap=8)
        doc.heading("Notes")
        doc.text(notes.strip() or "None.", 9)
        doc.heading("Joint angles over the gait cycle, before and after", keep_px=CURVE_ROW_PX)
        _curve_pages(doc, [before, after], bands or {}, labels)
    finally:
        doc.finish()
    return target


# -- clinical tests ---------------------------------------------------------------------------------
def _subject_line(subject: dict) -> str:
    parts = [f"Subject: {subject.get('id') or 'not recorded'}"]
    if subject.get("age_years") is not None:
        parts.append(f"age {float(subject['age_years']):.0f} years")
    if subject.get("sex"):
        parts.append(str(subject["sex"]))
    if subject.get("height_m") is not None:
        parts.append(f"height {float(subject['height_m']):.2f} m")
    if subject.get("weight_kg") is not None:
        parts.append(f"weight {float(subject['weight_kg']):.0f} kg")
    return ", ".join(parts)


def _trend_plot(doc: _Document, rect: QRectF, key: str, visits, reference: dict | None) -> None:
    """The main result of each visit, oldest on the left, with the reference as a band or line."""
    from mimucap.session.recorded.clinical_test_results import QUANTITIES

    values = [v.values.get(key) for v in visits]
    finite = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    ref = {k: float(reference[k]) for k in ("mean", "ci95_low", "ci95_high", "p25", "p75", "predicted", "lower_limit")
           if reference is not None and reference.get("key") == key and k in reference}
    span = finite + list(ref.values())
    if not span:
        return
    low, high = min(span + [0.0]), max(span) * 1.15
    ticks = nice_ticks(low, high, 5)
    name, unit, _digits = QUANTITIES[key]
    painter = doc.painter
    plot = QRectF(rect.left() + 60, rect.top() + 20, rect.width() - 70, rect.height() - 50)
    doc.font(8, True)
    painter.setPen(QColor(0, 0, 0))
    painter.drawText(QRectF(rect.left(), rect.top(), rect.width(), 18), int(Qt.AlignLeft), f"{name} ({unit})" if unit else name)

    def y_of(value: float) -> float:
        return plot.bottom() - (value - low) / (high - low) * plot.height()

    band = (ref.get("ci95_low"), ref.get("ci95_high")) if "ci95_low" in ref else (ref.get("p25"), ref.get("p75"))
    if band[0] is not None and band[1] is not None:
        painter.fillRect(QRectF(plot.left(), y_of(band[1]), plot.width(), y_of(band[0]) - y_of(band[1])), QColor(220, 235, 220))
    for level in (ref.get("mean"), ref.get("predicted"), ref.get("lower_limit")):
        if level is not None:
            painter.setPen(QPen(QColor(60, 140, 60), 1, Qt.DashLine))
            painter.drawLine(QPointF(plot.left(), y_of(level)), QPointF(plot.right(), y_of(level)))
    doc.font(7)
    painter.setPen(QPen(QColor(120, 120, 120), 1))
    for tick, label in ticks:
        painter.drawLine(QPointF(plot.left() - 3, y_of(tick)), QPointF(plot.left(), y_of(tick)))
        painter.drawText(QRectF(rect.left(), y_of(tick) - 8, 55, 16), int(Qt.AlignRight | Qt.AlignVCenter), label)
    painter.drawRect(plot)
    n = len(visits)
    xs = [plot.left() + plot.width() * ((k + 0.5) / n) for k in range(n)]
    points = [QPointF(x, y_of(float(v))) for x, v in zip(xs, values) if v is not None and math.isfinite(float(v))]
    painter.setPen(QPen(QColor(30, 100, 200), 2))
    if len(points) > 1:
        painter.drawPolyline(QPolygonF(points))
    painter.setBrush(QColor(30, 100, 200))
    for point in points:
        painter.drawEllipse(point, 4, 4)
    painter.setBrush(Qt.NoBrush)
    painter.setPen(QColor(0, 0, 0))
    for x, visit in zip(xs, visits):
        date = local_time_text(visit.recorded_utc).split(",")[0]
        half = painter.fontMetrics().horizontalAdvance(date) / 2 + 6  # the whole date, however the device scales
        painter.drawText(QRectF(x - half, plot.bottom() + 4, 2 * half, 24), int(Qt.AlignHCenter | Qt.AlignTop), date)
    doc.y = rect.bottom() + 10


def clinical_test_section(doc: _Document, result, earlier) -> None:
    """One clinical test: its results beside the reference, how its start was found, and the
    subject's earlier visits (``earlier``: :class:`~mimucap.session.recorded.clinical_test_results.Visit`)."""
    from mimucap.session.recorded.clinical_test_results import (
        MAIN_RESULT, Visit, format_quantity, result_rows, start_text,
    )
    from mimucap.session.recorded.clinical_tests import TEST_NAMES

    doc.text(TEST_NAMES[result.test], 13, True, gap=4)
    doc.text(f"Test from {result.start_s:.1f} s to {result.end_s:.1f} s of the recording, timed from "
             f"{start_text(result.started_by)}.", 8.5)
    doc.table(["Result", "Value", "Reference"], [list(row) for row in result_rows(result)], [0.34, 0.16, 0.5])
    if result.reference is not None:
        doc.text(f"Reference: {result.reference['group']}, {result.reference['statistic']}. "
                 f"Source: {result.reference['source'].rstrip('.')}.", 7.5, colour=QColor(70, 70, 70))
    else:
        doc.text(f"No reference: {result.reference_note}.", 7.5, colour=QColor(70, 70, 70))
    key = MAIN_RESULT[result.test]
    doc.heading("Visits")
    this = Visit(result.recorded_utc, "this session", dict(result.values), result.result)
    visits = list(earlier)
    if not visits:
        doc.text("No earlier visit of this subject with this test in the library.", 8.5, gap=6)
        return
    rows = [[local_time_text(v.recorded_utc), v.session, format_quantity(key, v.values.get(key))] for v in visits]
    rows.append(["this visit", result.provenance.source_file if result.provenance is not None else "",
                 format_quantity(key, result.values.get(key))])
    doc.table(["Recorded", "Session", TEST_NAMES[result.test] + ": " + key.split("_")[0]], rows, [0.25, 0.5, 0.25])
    doc.need(300)
    _trend_plot(doc, QRectF(0, doc.y, doc.width, 280), key, visits + [this], result.reference)


def _guided_test_page(doc: _Document, analysis: SessionAnalysis) -> None:
    """A page for the clinical test a guided recording holds (its settings in the metadata):
    the result from the sensors, the reference, the subject's earlier visits in the library; a
    result that cannot be computed says why."""
    from mimucap.session.recorded.clinical_test_results import earlier_results
    from mimucap.session.recorded.clinical_tests import TEST_NAMES, clinical_test

    review = analysis.review
    test = (review.session.metadata.get("clinical_test") or {}).get("test")
    if test not in TEST_NAMES:
        return
    doc.new_page()
    try:
        result = clinical_test(review, test)
    except ValueError as error:
        doc.text(TEST_NAMES[test], 13, True, gap=4)
        doc.text(f"No result: {error}.", 9, colour=DOUBT_COLOUR)
        return
    clinical_test_section(doc, result, earlier_results(review.path, test))


def write_clinical_test_report(path: str | Path, result, earlier=()) -> Path:
    """A clinical test's report (PDF): page 1 names the subject, the session, what the result
    holds (calibrations, result kind, software), then the test's page with the earlier visits."""
    from mimucap.session.recorded.clinical_tests import TEST_NAMES

    target = Path(path)
    doc = _Document(target, f"MimuCap clinical test report: {TEST_NAMES[result.test]}")
    try:
        doc.text(f"Clinical test report: {TEST_NAMES[result.test]}", 16, True, gap=8)
        doc.text(_subject_line(result.subject), 10)
        if result.provenance is not None:
            doc.heading("What this report holds")
            for label, text in result.provenance.items():
                doc.text(f"{label}: {text}.", 8, gap=2)
        doc.y += 6
        clinical_test_section(doc, result, earlier)
    finally:
        doc.finish()
    return target


def write_trend_report(path: str | Path, subject_id: str, test: str, key: str, visits, reference: dict | None) -> Path:
    """One subject's results of one clinical test across visits (``visits``:
    :class:`~mimucap.session.recorded.clinical_test_results.Visit`, oldest first) as a printable PDF page:
    the chart of result ``key`` with the reference of the latest visit, and the table."""
    from mimucap.session.recorded.clinical_test_results import QUANTITIES, format_quantity
    from mimucap.session.recorded.clinical_tests import TEST_NAMES

    target = Path(path)
    doc = _Document(target, f"MimuCap trend: {TEST_NAMES[test]}, {subject_id}")
    try:
        doc.text(f"{TEST_NAMES[test]}: {QUANTITIES[key][0].lower()} across visits", 16, True, gap=8)
        doc.text(f"Subject: {subject_id}    {len(visits)} visit{'s' if len(visits) != 1 else ''}", 10)
        if reference is not None:
            doc.text(f"Reference (latest visit): {reference.get('group', '')}, {reference.get('statistic', '')}. "
                     f"Source: {reference.get('source', '').rstrip('.')}.", 7.5, colour=QColor(70, 70, 70))
        doc.need(460)
        _trend_plot(doc, QRectF(0, doc.y, doc.width, 440), key, visits, reference)
        doc.table(["Recorded", "Session", "Result kind", QUANTITIES[key][0]],
                  [[local_time_text(v.recorded_utc), v.session, v.result.replace("_", " "),
                    format_quantity(key, v.values.get(key))] for v in visits], [0.22, 0.46, 0.14, 0.18])
    finally:
        doc.finish()
    return target
