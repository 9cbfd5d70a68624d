"""``vtkPolyData`` from numpy arrays, in one step: no per-cell Python loop.

:func:`polydata` takes the points as a VTK array (often sharing memory with a numpy array
that is moved in place every frame) and the cells as an ``(m, k)`` integer array of point
indices: ``k`` = 1 vertices, 2 lines, 3 triangles. :func:`colour_by_point_rgb` has a mapper
draw such a polydata in the RGB bytes of its point scalars; :func:`shaded_mesh` makes the
triangles of moving numpy points, normals and colours one such polydata.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from vtkmodules.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray
from vtkmodules.vtkCommonCore import vtkPoints
from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData

_SET_CELLS = {1: vtkPolyData.SetVerts, 2: vtkPolyData.SetLines, 3: vtkPolyData.SetPolys}


def polydata(points_array, cells: NDArray[np.int64]) -> vtkPolyData:
    """A polydata of ``points_array`` (a VTK array of ``(n, 3)`` points, kept by reference)
    with the cells ``cells`` ``(m, k)``: vertices (k = 1), lines (2) or triangles (3)."""
    cells = np.ascontiguousarray(cells, dtype=np.int64)
    size = cells.shape[1]
    if size not in _SET_CELLS:
        raise ValueError(f"cells of {size} points: use 1 (vertices), 2 (lines) or 3 (triangles)")
    offsets = numpy_to_vtkIdTypeArray(np.arange(0, size * len(cells) + 1, size, dtype=np.int64), deep=True)
    connectivity = numpy_to_vtkIdTypeArray(cells.reshape(-1), deep=True)
    cell_array = vtkCellArray()
    cell_array.SetData(offsets, connectivity)
    points = vtkPoints()
    points.SetData(points_array)
    result = vtkPolyData()
    result.SetPoints(points)
    _SET_CELLS[size](result, cell_array)
    return result


def colour_by_point_rgb(mapper) -> None:
    """Have ``mapper`` colour by its input's point scalars, RGB bytes used as they are."""
    mapper.SetColorModeToDirectScalars()
    mapper.SetScalarModeToUsePointData()
    mapper.ScalarVisibilityOn()


def shaded_mesh(points: NDArray[np.float64], normals: NDArray[np.float64], colours: NDArray[np.uint8],
                triangles: NDArray[np.int64]) -> tuple[vtkPolyData, tuple]:
    """A polydata of ``triangles`` over ``points`` ``(n, 3)`` with point ``normals`` ``(n, 3)`` and
    RGB ``colours`` ``(n, 3)`` bytes, sharing memory with those numpy arrays (move them in place,
    then call ``Modified()`` on the VTK arrays returned, which the caller keeps referenced):
    ``(polydata, (vtk_points, vtk_normals, vtk_colours))``."""
    vtk_points = numpy_to_vtk(points, deep=False)
    vtk_normals = numpy_to_vtk(normals, deep=False)
    vtk_normals.SetName("Normals")
    vtk_colours = numpy_to_vtk(colours, deep=False)
    vtk_colours.SetName("Colours")
    result = polydata(vtk_points, triangles)
    result.GetPointData().SetNormals(vtk_normals)
    result.GetPointData().SetScalars(vtk_colours)
    return result, (vtk_points, vtk_normals, vtk_colours)
