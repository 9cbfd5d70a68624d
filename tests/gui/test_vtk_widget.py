"""The VTK render window in Qt: what it renders reaches the screen the right way up, the mouse
turns the camera, pictures of windows include it, and nothing renders after Finalize."""

from __future__ import annotations

import numpy as np
import pytest
from PyQt5 import QtCore, QtGui, QtWidgets
from vtkmodules.vtkFiltersSources import vtkSphereSource
from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper, vtkRenderer

from mimucap.gui.capture import grab_window
from mimucap.gui.vtk_widget import VtkWidget


def _scene(widget: VtkWidget) -> vtkRenderer:
    """A red unlit sphere right of centre on a blue background: the picture is not symmetric."""
    renderer = vtkRenderer()
    renderer.SetBackground(0.0, 0.0, 1.0)
    sphere = vtkSphereSource()
    sphere.SetCenter(0.6, 0.0, 0.0)
    sphere.SetRadius(0.5)
    mapper = vtkPolyDataMapper()
    mapper.SetInputConnection(sphere.GetOutputPort())
    actor = vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetColor(1.0, 0.0, 0.0)
    actor.GetProperty().LightingOff()
    renderer.AddActor(actor)
    widget.render_window.AddRenderer(renderer)
    camera = renderer.GetActiveCamera()
    camera.SetPosition(0.0, 0.0, 5.0)
    camera.SetFocalPoint(0.0, 0.0, 0.0)
    return renderer


@pytest.fixture
def view(qtbot):
    widget = VtkWidget()
    qtbot.addWidget(widget)
    widget.resize(320, 240)
    widget.renderer = _scene(widget)
    widget.show()
    qtbot.waitExposed(widget)
    widget.render()
    yield widget
    widget.Finalize()


def _rgb(image: QtGui.QImage) -> np.ndarray:
    """A copy of ``image``'s pixels, ``(height, width, 3)`` uint8."""
    image = image.convertToFormat(QtGui.QImage.Format_RGB888)
    ptr = image.constBits()
    ptr.setsize(image.sizeInBytes())
    rows = np.frombuffer(ptr, np.uint8).reshape(image.height(), image.bytesPerLine())
    return rows[:, : 3 * image.width()].reshape(image.height(), image.width(), 3).copy()


def _red_on_blue(pixels: np.ndarray, width: int) -> None:
    red = (pixels[:, :, 0] > 200) & (pixels[:, :, 2] < 50)
    blue = (pixels[:, :, 2] > 200) & (pixels[:, :, 0] < 50)
    assert red.mean() > 0.05 and blue.mean() > 0.5
    assert np.nonzero(red.any(axis=0))[0].mean() > width / 2  # right of centre, as in the scene


def test_the_frame_reaches_the_screen_the_right_way_up(view, qtbot):
    assert tuple(view.render_window.GetSize()) == (view.width(), view.height())
    image = view.image()
    assert (image.width(), image.height()) == (320, 240)
    _red_on_blue(_rgb(image), 320)
    # What the X server shows in the widget's window: the frame was presented, not only drawn.
    on_screen = _rgb(QtWidgets.QApplication.primaryScreen().grabWindow(int(view.winId())).toImage())
    _red_on_blue(on_screen, 320)
    np.testing.assert_array_equal(on_screen, _rgb(image))


def test_the_view_follows_a_resize(view, qtbot):
    view.resize(200, 300)
    qtbot.waitUntil(lambda: tuple(view.render_window.GetSize()) == (200, 300), timeout=2000)
    image = view.image()
    assert (image.width(), image.height()) == (200, 300)


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


def test_keys_do_not_reach_vtks_own_bindings(view, qtbot):
    camera = view.renderer.GetActiveCamera()
    before = camera.GetPosition()
    qtbot.keyClick(view, "r")  # VTK's "reset camera" would move it onto the sphere's bounds
    qtbot.keyClick(view, "w")  # and "w" would draw wireframes
    assert camera.GetPosition() == before
    assert view.renderer.GetActors().GetLastActor().GetProperty().GetRepresentation() == 2  # surface


def test_after_finalize_nothing_renders(view, qtbot, left_drag):
    count = []
    view.rendered.connect(lambda: count.append(1))
    view.Finalize()
    assert view.finalized
    view.render()
    view.repaint()
    view.resize(300, 200)
    left_drag(view, QtCore.QPoint(100, 100), QtCore.QPoint(10, 0))
    QtCore.QCoreApplication.processEvents()
    assert not count
    assert view.image().isNull()
    grab_window(view)  # a picture of a window with a closed view still works


def test_a_picture_of_a_window_has_each_3d_view_in_place(qtbot):
    window = QtWidgets.QWidget()
    qtbot.addWidget(window)
    layout = QtWidgets.QHBoxLayout(window)
    layout.setContentsMargins(0, 0, 0, 0)
    label = QtWidgets.QLabel("left of the view", window)
    label.setFixedWidth(150)
    label.setStyleSheet("background: white")
    layout.addWidget(label)
    view = VtkWidget(window)
    _scene(view)
    layout.addWidget(view)
    window.resize(470, 240)
    window.show()
    qtbot.waitExposed(window)
    qtbot.waitUntil(lambda: view.width() > 200, timeout=2000)
    pixels = _rgb(grab_window(window).toImage())
    corner = view.mapTo(window, QtCore.QPoint(0, 0))
    assert (pixels[:, : corner.x() - 2] > 200).all(axis=2).mean() > 0.5  # the label, white
    inside = pixels[corner.y():corner.y() + view.height(), corner.x():corner.x() + view.width()]
    _red_on_blue(inside, view.width())
    view.Finalize()


def test_only_the_views_ancestors_become_native_windows(qtbot):
    window = QtWidgets.QWidget()
    qtbot.addWidget(window)
    layout = QtWidgets.QVBoxLayout(window)
    box = QtWidgets.QWidget(window)
    box_layout = QtWidgets.QHBoxLayout(box)
    siblings = [QtWidgets.QPushButton(f"button {index}", box) for index in range(3)]
    for button in siblings:
        box_layout.addWidget(button)
    layout.addWidget(box)
    view = VtkWidget(window)
    layout.addWidget(view)
    window.show()
    qtbot.waitExposed(window)
    assert view.windowHandle() is not None and window.windowHandle() is not None
    assert box.windowHandle() is None and all(button.windowHandle() is None for button in siblings)
    view.Finalize()
