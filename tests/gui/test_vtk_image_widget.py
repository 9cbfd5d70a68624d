"""The offscreen VTK view: what it renders is what Qt shows, and the mouse turns the camera."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PyQt5 import QtCore, QtGui
from vtkmodules.vtkFiltersSources import vtkSphereSource
from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper, vtkRenderer

from mimucap.gui.software_gl import SOFTWARE_GL_THREADS
from mimucap.gui.vtk_image_widget import VtkImageWidget


@pytest.fixture
def view(qtbot):
    widget = VtkImageWidget()
    qtbot.addWidget(widget)
    widget.resize(320, 240)
    renderer = vtkRenderer()
    renderer.SetBackground(0.0, 0.0, 1.0)  # pure blue background
    sphere = vtkSphereSource()
    sphere.SetCenter(0.6, 0.0, 0.0)  # right of centre: the picture is not symmetric
    sphere.SetRadius(0.5)
    mapper = vtkPolyDataMapper()
    mapper.SetInputConnection(sphere.GetOutputPort())
    actor = vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetColor(1.0, 0.0, 0.0)
    actor.GetProperty().LightingOff()  # pure red
    renderer.AddActor(actor)
    widget.render_window.AddRenderer(renderer)
    renderer.GetActiveCamera().SetPosition(0.0, 0.0, 5.0)
    renderer.GetActiveCamera().SetFocalPoint(0.0, 0.0, 0.0)
    widget.renderer = renderer
    widget.show()
    qtbot.waitExposed(widget)
    widget.render()
    yield widget
    widget.Finalize()


def _rgb(image) -> np.ndarray:
    """A copy of ``image``'s pixels, ``(height, width, 3)`` uint8."""
    image = image.convertToFormat(QtGui.QImage.Format_RGB888)
    ptr = image.constBits()
    ptr.setsize(image.sizeInBytes())
    rows = np.frombuffer(ptr, np.uint8).reshape(image.height(), image.bytesPerLine())
    return rows[:, : 3 * image.width()].reshape(image.height(), image.width(), 3).copy()


def test_the_widget_shows_the_rendered_frame_the_right_way_up(view):
    assert tuple(view.render_window.GetSize()) == (view.width(), view.height())
    pixels = _rgb(view.grab().toImage())
    red = (pixels[:, :, 0] > 200) & (pixels[:, :, 2] < 50)
    blue = (pixels[:, :, 2] > 200) & (pixels[:, :, 0] < 50)
    assert red.mean() > 0.05 and blue.mean() > 0.5
    columns = np.nonzero(red.any(axis=0))[0]
    assert columns.mean() > view.width() / 2  # the sphere is right of centre, as in the scene
    np.testing.assert_array_equal(_rgb(view.image()), pixels)


def test_the_view_follows_a_resize(view, qtbot):
    view.resize(200, 300)
    qtbot.waitUntil(lambda: tuple(view.render_window.GetSize()) == (200, 300), timeout=2000)
    assert (view.image().width(), view.image().height()) == (200, 300)


def test_dragging_orbits_and_the_wheel_zooms(view, qtbot, left_drag):
    camera = view.renderer.GetActiveCamera()
    before = np.array(camera.GetPosition())
    frames = []
    view.rendered.connect(lambda: frames.append(1))
    centre = QtCore.QPoint(view.width() // 2, view.height() // 2)
    left_drag(view, centre, QtCore.QPoint(12, 0))
    after = np.array(camera.GetPosition())
    assert np.linalg.norm(after - before) > 0.5  # turned about the focal point ...
    assert np.linalg.norm(after) == pytest.approx(np.linalg.norm(before), rel=1e-6)  # ... at the same distance
    assert frames  # and each step was drawn
    distance = camera.GetDistance()
    wheel = QtGui.QWheelEvent(QtCore.QPointF(centre), QtCore.QPointF(view.mapToGlobal(centre)), QtCore.QPoint(0, 0),
                              QtCore.QPoint(0, 120), QtCore.Qt.NoButton, QtCore.Qt.NoModifier,
                              QtCore.Qt.NoScrollPhase, False)
    view.wheelEvent(wheel)
    assert camera.GetDistance() < distance


def test_after_finalize_nothing_renders(view):
    count = []
    view.rendered.connect(lambda: count.append(1))
    view.Finalize()
    assert view.finalized
    view.render()
    assert not count
    view.grab()  # painting the last picture still works


def test_labels_are_painted_over_the_frame_where_the_provider_puts_them(view):
    from mimucap.gui.vtk_image_widget import OverlayLabel

    view.label_provider = lambda: [OverlayLabel("WWW", 60.0, 40.0, (255, 255, 0))]
    view.render()
    assert view.labels == (OverlayLabel("WWW", 60.0, 40.0, (255, 255, 0)),)
    for image in (view.grab().toImage(), view.image()):
        pixels = _rgb(image)
        yellow = (pixels[:, :, 0] > 200) & (pixels[:, :, 1] > 200) & (pixels[:, :, 2] < 80)
        rows, columns = np.nonzero(yellow)
        assert len(rows) > 20  # the text is there, centred on its anchor, nowhere else
        assert abs(rows.mean() - 40.0) < 6.0 and abs(columns.mean() - 60.0) < 8.0
    view.label_provider = None
    view.render()
    pixels = _rgb(view.image())
    assert not ((pixels[:, :, 0] > 200) & (pixels[:, :, 1] > 200)).any()


def test_a_hint_is_boxed_in_the_middle_of_the_picture_until_cleared(view):
    view.render()
    plain = _rgb(view.image())
    view.set_hint("Waiting for data from the source…")
    for image in (view.grab().toImage(), view.image()):
        pixels = _rgb(image)
        changed = np.any(pixels != plain, axis=2)
        rows, columns = np.nonzero(changed)
        assert len(rows) > 500  # a box with text, centred, away from the edges
        assert abs(rows.mean() - 120.0) < 10.0 and abs(columns.mean() - 160.0) < 10.0
        assert rows.min() > 60 and rows.max() < 180 and columns.min() > 5 and columns.max() < 315
        white = (pixels[:, :, 0] > 220) & (pixels[:, :, 1] > 220) & (pixels[:, :, 2] > 220)
        assert white[changed].sum() > 20  # the text
    view.set_hint("")
    np.testing.assert_array_equal(_rgb(view.image()), plain)


def test_software_opengl_draws_without_helper_threads_unless_the_user_chose(qtbot, monkeypatch):
    monkeypatch.delenv("LP_NUM_THREADS", raising=False)
    widget = VtkImageWidget()
    qtbot.addWidget(widget)
    assert os.environ["LP_NUM_THREADS"] == SOFTWARE_GL_THREADS == "0"
    widget.Finalize()
    monkeypatch.setenv("LP_NUM_THREADS", "3")
    widget = VtkImageWidget()
    qtbot.addWidget(widget)
    assert os.environ["LP_NUM_THREADS"] == "3"
    widget.Finalize()


_COUNT_RASTERISER_THREADS = """
import os
from PyQt5 import QtWidgets
app = QtWidgets.QApplication(["t"])
from mimucap.gui.software_gl import SOFTWARE_GL_THREADS
from mimucap.gui.vtk_image_widget import VtkImageWidget
widget = VtkImageWidget()
widget.resize(200, 150)
widget.render()
names = [open(f"/proc/self/task/{tid}/comm").read().strip() for tid in os.listdir("/proc/self/task")]
renderer = widget.render_window.ReportCapabilities().split("OpenGL renderer string:")[-1].splitlines()[0]
print(sum(name.startswith("llvmpipe") for name in names), renderer.strip(), sep="|")
widget.Finalize()
"""


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs Linux /proc")
def test_a_new_process_rendering_on_llvmpipe_starts_no_rasteriser_threads():
    environ = {key: value for key, value in os.environ.items() if key != "LP_NUM_THREADS"}
    out = subprocess.run([sys.executable, "-c", _COUNT_RASTERISER_THREADS], env=environ,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    threads, renderer = out.stdout.strip().splitlines()[-1].split("|", 1)
    if not renderer.startswith("llvmpipe"):
        pytest.skip(f"OpenGL is not Mesa's llvmpipe here: {renderer}")
    assert int(threads) == 0
