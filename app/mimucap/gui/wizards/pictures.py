"""Instruction pictures for the calibration wizards, drawn with ``QPainter``.

* Pose pictures: a front view of the subject in N-pose (arms hanging, palms forward) or in
  T-pose with the right, left or both arms raised sideways to the horizontal. The subject faces
  the viewer, so the subject's right arm is drawn on the picture's left.
* Axis pictures: a sensor box drawn in oblique projection with its printed x, y, z axes; the
  axis to turn about now is drawn thick in its colour with a circular arrow around it, and
  every axis carries its progress as a ring filling up to a full turn.
* Protocol pictures: a figure-8 path for the figure-8 protocol, a tumbling box for free motion.

Everything here only draws; what to draw comes from the session-layer procedures.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from PyQt5.QtCore import QPointF, QRectF, QSize, Qt
from PyQt5.QtGui import QColor, QFont, QPainter, QPainterPath, QPen, QPixmap, QPolygonF
from PyQt5.QtWidgets import QSizePolicy, QWidget

#: Colour of each sensor axis (the usual x red, y green, z blue).
AXIS_COLOURS = {"x": QColor(214, 39, 40), "y": QColor(44, 160, 44), "z": QColor(31, 119, 180)}
#: Screen direction of each sensor axis in the oblique projection (x right, y into the page, z up).
_AXIS_DIRECTIONS = {"x": (1.0, 0.0), "y": (0.55, -0.45), "z": (0.0, -1.0)}
_SKIN = QColor(70, 80, 95)
_RAISED = QColor(230, 120, 20)
_FAINT = QColor(170, 175, 185)

POSES = ("npose", "tpose")
ARMS = ("both", "right", "left")
PROTOCOL_PICTURES = ("figure8", "free")


def _pen(colour: QColor, width: float, style=Qt.SolidLine) -> QPen:
    pen = QPen(colour, width, style)
    pen.setCapStyle(Qt.RoundCap)
    pen.setJoinStyle(Qt.RoundJoin)
    return pen


def draw_pose(painter: QPainter, rect: QRectF, pose: str, arms: str = "both") -> None:
    """Draw a front-view stick figure in ``pose`` (``"npose"``/``"tpose"``) inside ``rect``.

    ``arms`` (``"both"``, ``"right"``, ``"left"``) says which arm is raised in T-pose; the
    raised arm is drawn in orange with a dashed trace of its N-pose position and an arc
    arrow of the 90° movement. In N-pose ``arms`` is ignored.
    """
    if pose not in POSES:
        raise ValueError(f"unknown pose {pose!r}; expected one of {POSES}")
    if arms not in ARMS:
        raise ValueError(f"unknown arm choice {arms!r}; expected one of {ARMS}")
    painter.save()
    painter.setRenderHint(QPainter.Antialiasing, True)
    unit = min(rect.width() / 2.2, rect.height() / 1.15)
    cx = rect.center().x()
    top = rect.center().y() - 0.55 * unit
    head_r = 0.065 * unit
    neck = QPointF(cx, top + 2 * head_r + 0.02 * unit)
    shoulder_y = neck.y() + 0.04 * unit
    shoulder_half = 0.13 * unit
    hip_y = shoulder_y + 0.36 * unit
    hip_half = 0.08 * unit
    arm_len = 0.36 * unit
    leg_len = 0.50 * unit
    width = max(2.0, 0.035 * unit)

    painter.setPen(_pen(_SKIN, width))
    painter.setBrush(Qt.NoBrush)
    painter.drawEllipse(QPointF(cx, top + head_r), head_r, head_r)
    # Trunk as a closed outline: shoulders to hips.
    trunk = QPolygonF(
        [
            QPointF(cx - shoulder_half, shoulder_y),
            QPointF(cx + shoulder_half, shoulder_y),
            QPointF(cx + hip_half, hip_y),
            QPointF(cx - hip_half, hip_y),
        ]
    )
    painter.drawPolygon(trunk)
    painter.drawLine(QPointF(cx, top + 2 * head_r), QPointF(cx, shoulder_y))
    for side in (-1.0, 1.0):
        hip = QPointF(cx + side * hip_half * 0.7, hip_y)
        painter.drawLine(hip, QPointF(hip.x() + side * 0.03 * unit, hip_y + leg_len))
    # Arms: the subject faces the viewer, so the subject's right arm is on the picture's left.
    for side_name, side in (("right", -1.0), ("left", 1.0)):
        shoulder = QPointF(cx + side * shoulder_half, shoulder_y)
        hanging = QPointF(shoulder.x() + side * 0.02 * unit, shoulder_y + arm_len)
        raised = pose == "tpose" and arms in ("both", side_name)
        if raised:
            horizontal = QPointF(shoulder.x() + side * arm_len, shoulder_y)
            painter.setPen(_pen(_FAINT, width * 0.6, Qt.DashLine))
            painter.drawLine(shoulder, hanging)
            _draw_arc_arrow(painter, shoulder, arm_len * 0.75, side, width * 0.6)
            painter.setPen(_pen(_RAISED, width * 1.3))
            painter.drawLine(shoulder, horizontal)
            painter.setPen(_pen(_SKIN, width))
        else:
            painter.drawLine(shoulder, hanging)
    font = QFont(painter.font())
    font.setPointSizeF(max(7.0, 0.045 * unit))
    painter.setFont(font)
    painter.setPen(_pen(_SKIN, 1))
    label_y = hip_y + leg_len + 0.08 * unit
    painter.drawText(QRectF(cx - unit, label_y - 0.05 * unit, 0.9 * unit, 0.1 * unit),
                     Qt.AlignRight | Qt.AlignVCenter, "subject's right")
    painter.drawText(QRectF(cx + 0.1 * unit, label_y - 0.05 * unit, 0.9 * unit, 0.1 * unit),
                     Qt.AlignLeft | Qt.AlignVCenter, "subject's left")
    painter.restore()


def _draw_arc_arrow(painter: QPainter, centre: QPointF, radius: float, side: float, width: float) -> None:
    """A quarter arc from straight down to horizontal on ``side`` (−1 left of screen, +1 right)."""
    path = QPainterPath()
    rect = QRectF(centre.x() - radius, centre.y() - radius, 2 * radius, 2 * radius)
    # Qt angles: 0° = 3 o'clock, positive counter-clockwise; straight down is 270°.
    start = 270.0
    span = 90.0 if side > 0 else -90.0
    path.arcMoveTo(rect, start)
    path.arcTo(rect, start, span)
    painter.setPen(_pen(_RAISED, width, Qt.DashLine))
    painter.drawPath(path)
    end = path.currentPosition()
    _arrow_head(painter, end, (0.0, -1.0), 3.5 * width, _RAISED)


def _arrow_head(painter: QPainter, tip: QPointF, direction: tuple[float, float], size: float, colour: QColor) -> None:
    dx, dy = direction
    norm = math.hypot(dx, dy) or 1.0
    dx, dy = dx / norm, dy / norm
    left = QPointF(tip.x() - size * dx + 0.5 * size * dy, tip.y() - size * dy - 0.5 * size * dx)
    right = QPointF(tip.x() - size * dx - 0.5 * size * dy, tip.y() - size * dy + 0.5 * size * dx)
    painter.save()
    painter.setPen(_pen(colour, 1))
    painter.setBrush(colour)
    painter.drawPolygon(QPolygonF([tip, left, right]))
    painter.restore()


def draw_axis_turn(
    painter: QPainter,
    rect: QRectF,
    axis: str | None,
    progress_deg: Mapping[str, float] | None = None,
    full_turn_deg: float = 330.0,
) -> None:
    """Draw the sensor box with its axes; highlight ``axis`` (``"x"``, ``"y"``, ``"z"`` or None).

    ``progress_deg`` maps each axis to the degrees already turned about it; each axis end
    carries a ring that fills up to ``full_turn_deg`` and turns into a check mark when done.
    """
    if axis is not None and axis not in AXIS_COLOURS:
        raise ValueError(f"unknown axis {axis!r}; expected x, y or z")
    progress_deg = dict(progress_deg or {})
    painter.save()
    painter.setRenderHint(QPainter.Antialiasing, True)
    unit = min(rect.width(), rect.height())
    c = rect.center()
    box = 0.17 * unit
    # Oblique box: front face square, depth along the y direction.
    dx, dy = _AXIS_DIRECTIONS["y"]
    depth = QPointF(dx * box * 0.8, dy * box * 0.8)
    front = [QPointF(c.x() - box, c.y() - box * 0.45), QPointF(c.x() + box, c.y() - box * 0.45),
             QPointF(c.x() + box, c.y() + box * 0.45), QPointF(c.x() - box, c.y() + box * 0.45)]
    back = [p + depth for p in front]
    painter.setPen(_pen(_SKIN, 1.5))
    painter.setBrush(QColor(225, 228, 235))
    painter.drawPolygon(QPolygonF([front[0], back[0], back[1], front[1]]))
    painter.drawPolygon(QPolygonF([front[1], back[1], back[2], front[2]]))
    painter.setBrush(QColor(240, 242, 246))
    painter.drawPolygon(QPolygonF(front))
    font = QFont(painter.font())
    font.setPointSizeF(max(7.0, 0.05 * unit))
    font.setBold(True)
    painter.setFont(font)
    axis_len = 0.36 * unit
    for name, (ux, uy) in _AXIS_DIRECTIONS.items():
        colour = AXIS_COLOURS[name]
        active = name == axis
        done = progress_deg.get(name, 0.0) >= full_turn_deg
        tip = QPointF(c.x() + ux * axis_len, c.y() + uy * axis_len)
        shown = colour if (active or axis is None or done) else _FAINT
        painter.setPen(_pen(shown, 5.0 if active else 2.5))
        painter.drawLine(c, tip)
        _arrow_head(painter, tip, (ux, uy), 14.0 if active else 9.0, shown)
        label = QPointF(tip.x() + ux * 0.06 * unit, tip.y() + uy * 0.06 * unit)
        painter.setPen(_pen(shown, 1))
        painter.drawText(QRectF(label.x() - 20, label.y() - 12, 40, 24), Qt.AlignCenter, name)
        if name in progress_deg:
            _progress_ring(painter, QPointF(c.x() + ux * axis_len * 0.62, c.y() + uy * axis_len * 0.62),
                           0.045 * unit, min(1.0, progress_deg[name] / full_turn_deg), colour, done)
        if active:
            _turn_arrow(painter, c, (ux, uy), axis_len * 0.78, 0.11 * unit, colour)
    painter.restore()


def _turn_arrow(painter: QPainter, c: QPointF, direction: tuple[float, float], along: float,
                radius: float, colour: QColor) -> None:
    """A circular arrow (ellipse seen obliquely) around the axis, ``along`` from the centre."""
    ux, uy = direction
    centre = QPointF(c.x() + ux * along, c.y() + uy * along)
    # The circle lies in the plane normal to the axis: drawn as an ellipse squashed along it.
    angle_deg = math.degrees(math.atan2(uy, ux))
    painter.save()
    painter.translate(centre)
    painter.rotate(angle_deg)
    rect = QRectF(-0.35 * radius, -radius, 0.7 * radius, 2 * radius)
    path = QPainterPath()
    path.arcMoveTo(rect, 110.0)
    path.arcTo(rect, 110.0, 300.0)
    painter.setPen(_pen(colour, 3.0))
    painter.setBrush(Qt.NoBrush)
    painter.drawPath(path)
    end = path.currentPosition()
    p_before = path.pointAtPercent(0.97)
    _arrow_head(painter, end, (end.x() - p_before.x(), end.y() - p_before.y()), 12.0, colour)
    painter.restore()


def _progress_ring(painter: QPainter, centre: QPointF, radius: float, fraction: float,
                   colour: QColor, done: bool) -> None:
    rect = QRectF(centre.x() - radius, centre.y() - radius, 2 * radius, 2 * radius)
    painter.save()
    painter.setPen(_pen(_FAINT, 2.0))
    painter.setBrush(QColor(255, 255, 255))
    painter.drawEllipse(rect)
    painter.setPen(Qt.NoPen)
    painter.setBrush(colour)
    painter.drawPie(rect, 90 * 16, -int(round(360 * 16 * fraction)))
    if done:
        painter.setPen(_pen(QColor(255, 255, 255), max(2.0, radius * 0.25)))
        painter.drawPolyline(QPolygonF([QPointF(centre.x() - 0.5 * radius, centre.y()),
                                        QPointF(centre.x() - 0.1 * radius, centre.y() + 0.4 * radius),
                                        QPointF(centre.x() + 0.55 * radius, centre.y() - 0.45 * radius)]))
    painter.restore()


def draw_protocol(painter: QPainter, rect: QRectF, protocol: str) -> None:
    """Draw the motion of the ``"figure8"`` or ``"free"`` protocol inside ``rect``."""
    if protocol not in PROTOCOL_PICTURES:
        raise ValueError(f"unknown protocol picture {protocol!r}; expected one of {PROTOCOL_PICTURES}")
    painter.save()
    painter.setRenderHint(QPainter.Antialiasing, True)
    unit = min(rect.width(), rect.height())
    c = rect.center()
    colour = QColor(31, 119, 180)
    path = QPainterPath()
    n = 200
    if protocol == "figure8":
        a = 0.42 * unit
        for i in range(n + 1):
            t = 2 * math.pi * i / n
            # Lemniscate of Gerono seen slightly tilted, so it reads as a 3D loop.
            p = QPointF(c.x() + a * math.sin(t), c.y() + 0.5 * a * math.sin(t) * math.cos(t) + 0.08 * a * math.cos(t))
            path.moveTo(p) if i == 0 else path.lineTo(p)
    else:
        for i in range(n + 1):
            t = 2 * math.pi * i / n
            r = 0.3 * unit * (0.75 + 0.25 * math.cos(3 * t))
            p = QPointF(c.x() + r * math.cos(t), c.y() + 0.8 * r * math.sin(t))
            path.moveTo(p) if i == 0 else path.lineTo(p)
    painter.setPen(_pen(colour, 3.0))
    painter.drawPath(path)
    end = path.currentPosition()
    before = path.pointAtPercent(0.98)
    _arrow_head(painter, end, (end.x() - before.x(), end.y() - before.y()), 14.0, colour)
    painter.setPen(_pen(_SKIN, 1.5))
    painter.setBrush(QColor(240, 242, 246))
    box = 0.07 * unit
    painter.drawRect(QRectF(c.x() - box, c.y() - 0.6 * box, 2 * box, 1.2 * box))
    painter.restore()


class PictureWidget(QWidget):
    """A widget showing one instruction picture: a pose, an axis to turn about, or a protocol.

    Call :meth:`show_pose`, :meth:`show_axis` or :meth:`show_protocol`; the widget repaints.
    """

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._kind = "pose"
        self._pose = "npose"
        self._arms = "both"
        self._axis: str | None = None
        self._progress: dict[str, float] = {}
        self._full_turn_deg = 330.0
        self._protocol = "figure8"
        self.setMinimumSize(QSize(220, 220))
        self.setSizePolicy(QSizePolicy.Expanding, QSizePolicy.Expanding)
        self.setAutoFillBackground(True)
        palette = self.palette()
        palette.setColor(self.backgroundRole(), QColor(255, 255, 255))
        self.setPalette(palette)

    @property
    def description(self) -> str:
        """What the picture shows, in words (also the accessible description)."""
        if self._kind == "pose":
            return "N-pose" if self._pose == "npose" else f"T-pose ({self._arms} arm{'s' if self._arms == 'both' else ''})"
        if self._kind == "axis":
            return f"turn about {self._axis}" if self._axis else "sensor axes"
        return self._protocol

    def show_pose(self, pose: str, arms: str = "both") -> None:
        if pose not in POSES or arms not in ARMS:
            raise ValueError(f"unknown pose/arms {pose!r}/{arms!r}")
        self._kind, self._pose, self._arms = "pose", pose, arms
        self._changed()

    def show_axis(self, axis: str | None, progress_deg: Mapping[str, float] | None = None,
                  full_turn_deg: float = 330.0) -> None:
        if axis is not None and axis not in AXIS_COLOURS:
            raise ValueError(f"unknown axis {axis!r}")
        self._kind, self._axis = "axis", axis
        self._progress = dict(progress_deg or {})
        self._full_turn_deg = float(full_turn_deg)
        self._changed()

    def show_protocol(self, protocol: str) -> None:
        if protocol not in PROTOCOL_PICTURES:
            raise ValueError(f"unknown protocol picture {protocol!r}")
        self._kind, self._protocol = "protocol", protocol
        self._changed()

    def _changed(self) -> None:
        self.setAccessibleDescription(self.description)
        self.setToolTip(self.description)
        self.update()

    def paintEvent(self, event) -> None:  # noqa: N802 (Qt name)
        painter = QPainter(self)
        try:
            self.paint_into(painter, QRectF(self.rect()))
        finally:
            painter.end()

    def paint_into(self, painter: QPainter, rect: QRectF) -> None:
        """Draw the current picture into ``rect`` of any paint device."""
        if self._kind == "pose":
            draw_pose(painter, rect, self._pose, self._arms)
        elif self._kind == "axis":
            draw_axis_turn(painter, rect, self._axis, self._progress, self._full_turn_deg)
        else:
            draw_protocol(painter, rect, self._protocol)

    def to_pixmap(self, size: QSize = QSize(320, 320)) -> QPixmap:
        """The current picture rendered on a white pixmap of ``size``."""
        pixmap = QPixmap(size)
        pixmap.fill(QColor(255, 255, 255))
        painter = QPainter(pixmap)
        try:
            self.paint_into(painter, QRectF(0, 0, size.width(), size.height()))
        finally:
            painter.end()
        return pixmap
