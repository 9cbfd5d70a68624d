"""PNG figure of the protocol study: one panel per protocol, like the figures of Choe
et al., "Study of calibration method of low-cost MEMS magnetometer".

Each panel shows, in the sensor frame (µT), the raw samples of the protocol's first
accepted trial (dots), the ellipsoid fitted to them (dark wireframe) and the reference
ellipsoid (light translucent surface), with the protocol, its centre and radii RMSE. Drawn
with VTK off screen (no window, no display needed where VTK has EGL or OSMesa); VTK is
already a MimuCap dependency, so no plotting library is added.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mimucap.cli import check_output_path
from mimucap.core.magcal.fit import Ellipsoid, symmetric_sqrt
from mimucap.core.magcal.study import StudyResult

#: Panel size in pixels and panels per row.
PANEL_PX = 360
PANELS_PER_ROW = 4


def _ellipsoid_actor(ellipsoid: Ellipsoid, colour: tuple[float, float, float], wireframe: bool):
    from vtkmodules.vtkCommonMath import vtkMatrix4x4
    from vtkmodules.vtkCommonTransforms import vtkTransform
    from vtkmodules.vtkFiltersGeneral import vtkTransformFilter
    from vtkmodules.vtkFiltersSources import vtkSphereSource
    from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper

    sphere = vtkSphereSource()
    sphere.SetRadius(1.0)
    sphere.SetThetaResolution(18)
    sphere.SetPhiResolution(12)
    # Unit sphere u → centre + Q^(-1/2) u, the ellipsoid (h − c)ᵀ Q (h − c) = 1.
    linear = np.linalg.inv(symmetric_sqrt(ellipsoid.shape_matrix))
    matrix = vtkMatrix4x4()
    for i in range(3):
        for j in range(3):
            matrix.SetElement(i, j, float(linear[i, j]))
        matrix.SetElement(i, 3, float(ellipsoid.centre[i]))
    transform = vtkTransform()
    transform.SetMatrix(matrix)
    shaped = vtkTransformFilter()
    shaped.SetInputConnection(sphere.GetOutputPort())
    shaped.SetTransform(transform)
    mapper = vtkPolyDataMapper()
    mapper.SetInputConnection(shaped.GetOutputPort())
    actor = vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetColor(*colour)
    if wireframe:
        actor.GetProperty().SetRepresentationToWireframe()
        actor.GetProperty().SetLineWidth(1.0)
    else:
        actor.GetProperty().SetOpacity(0.25)
    return actor


def _points_actor(samples: np.ndarray):
    from vtkmodules.vtkCommonCore import vtkPoints
    from vtkmodules.vtkCommonDataModel import vtkPolyData
    from vtkmodules.vtkFiltersGeneral import vtkVertexGlyphFilter
    from vtkmodules.vtkRenderingCore import vtkActor, vtkPolyDataMapper

    finite = samples[np.all(np.isfinite(samples), axis=1)]
    points = vtkPoints()
    points.SetNumberOfPoints(len(finite))
    for index, point in enumerate(finite):
        points.SetPoint(index, float(point[0]), float(point[1]), float(point[2]))
    data = vtkPolyData()
    data.SetPoints(points)
    glyphs = vtkVertexGlyphFilter()
    glyphs.SetInputData(data)
    mapper = vtkPolyDataMapper()
    mapper.SetInputConnection(glyphs.GetOutputPort())
    actor = vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetColor(0.85, 0.2, 0.1)
    actor.GetProperty().SetPointSize(3.0)
    return actor


def render_study_png(result: StudyResult, path: str | Path) -> Path:
    """Write the study figure to ``path`` (PNG) and return it; ``OSError`` if VTK cannot render
    off screen or the file cannot be written."""
    import vtkmodules.vtkRenderingFreeType  # noqa: F401  (text rendering)
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (render window implementation)
    from vtkmodules.vtkCommonCore import vtkLogger
    from vtkmodules.vtkIOImage import vtkPNGWriter
    from vtkmodules.vtkRenderingCore import (
        vtkRenderer,
        vtkRenderWindow,
        vtkTextActor,
        vtkWindowToImageFilter,
    )

    path = check_output_path(path)
    panels = list(result.protocols)
    rows = max(1, math.ceil(len(panels) / PANELS_PER_ROW))
    columns = min(PANELS_PER_ROW, max(1, len(panels)))
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)
    window = vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.SetSize(columns * PANEL_PX, rows * PANEL_PX)
    for index, item in enumerate(panels):
        row, column = divmod(index, PANELS_PER_ROW)
        renderer = vtkRenderer()
        renderer.SetViewport(
            column / columns, 1.0 - (row + 1) / rows, (column + 1) / columns, 1.0 - row / rows
        )
        renderer.SetBackground(1.0, 1.0, 1.0)
        if result.reference is not None:
            renderer.AddActor(_ellipsoid_actor(result.reference, (0.55, 0.7, 0.9), wireframe=False))
        if item.example_fit is not None and item.example_mag_uT is not None:
            renderer.AddActor(_ellipsoid_actor(item.example_fit, (0.35, 0.35, 0.55), wireframe=True))
            renderer.AddActor(_points_actor(item.example_mag_uT))
        label = vtkTextActor()
        if math.isnan(item.centre_rmse_uT):
            label.SetInput(f"{item.key}\nall fits refused")
        else:
            label.SetInput(
                f"{item.key}\ncentre RMSE {item.centre_rmse_uT:.2f} uT\nradii RMSE {item.radii_rmse_uT:.2f} uT"
            )
        label.GetTextProperty().SetColor(0.0, 0.0, 0.0)
        label.GetTextProperty().SetFontSize(14)
        label.SetPosition(8, 8)
        renderer.AddViewProp(label)
        camera = renderer.GetActiveCamera()
        camera.SetPosition(1.0, -1.6, 0.9)
        camera.SetFocalPoint(0.0, 0.0, 0.0)
        camera.SetViewUp(0.0, 0.0, 1.0)
        renderer.ResetCamera()
        window.AddRenderer(renderer)
    window.Render()
    image = vtkWindowToImageFilter()
    image.SetInput(window)
    image.Update()
    writer = vtkPNGWriter()
    writer.SetFileName(str(path))
    writer.SetInputConnection(image.GetOutputPort())
    writer.Write()
    window.Finalize()
    if not path.is_file() or path.stat().st_size == 0:
        raise OSError(f"could not render the study figure to {path} (no off-screen OpenGL?)")
    return path
