"""Copies of one unit shape placed by ``(4, 4)`` matrices, all in one vertex buffer.

A :class:`UnitShape` is a triangulated VTK source as numpy arrays; :class:`PlacedCopies` owns
a run of vertices of a shared buffer, ``count`` copies of the shape, and writes each copy's
vertices and normals from its matrix every frame (``points = M[:3, :3] @ p + M[:3, 3]``,
``normals ∝ M[:3, :3]^-T @ n``): one buffer upload and one draw call for every copy, where one
actor per copy would cost a draw call, a matrix and a state change each.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkFiltersCore import vtkTriangleFilter


@dataclass(frozen=True)
class UnitShape:
    """A unit shape: ``points``/``normals`` ``(n, 3)`` float, ``triangles`` ``(m, 3)`` int."""

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    triangles: NDArray[np.int64]


def unit_shape(source) -> UnitShape:
    """The triangles of VTK ``source`` (its output has point normals) as a :class:`UnitShape`."""
    triangulate = vtkTriangleFilter()
    triangulate.SetInputConnection(source.GetOutputPort())
    triangulate.Update()
    poly = triangulate.GetOutput()
    points = vtk_to_numpy(poly.GetPoints().GetData()).astype(float)
    normals = vtk_to_numpy(poly.GetPointData().GetNormals()).astype(float)
    connectivity = vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).astype(np.int64)
    return UnitShape(points, normals, connectivity.reshape(-1, 3))


def rgb_bytes(colour) -> NDArray[np.uint8]:
    """An RGB colour of floats 0..1 as bytes."""
    return np.round(255.0 * np.asarray(colour)).astype(np.uint8)


class PlacedCopies:
    """``count`` copies of ``template`` occupying vertices ``first`` … ``first + count * n - 1``."""

    def __init__(self, template: UnitShape, count: int, first: int) -> None:
        self.template = template
        self.count = count
        self.first = first
        self.stop = first + count * len(template.points)

    def vertex_range(self, index: int) -> slice:
        n = len(self.template.points)
        return slice(self.first + index * n, self.first + (index + 1) * n)

    def place(self, matrices: NDArray[np.float64], points_out: np.ndarray, normals_out: np.ndarray) -> None:
        """Write the vertices and unit normals of every copy placed by ``matrices`` ``(count, 4, 4)``."""
        if self.count == 0:
            return
        linear = matrices[:, :3, :3]
        # Row vectors: p' = p @ L^T + t ; n' ∝ n @ L^-1 (the inverse transpose, transposed).
        placed = self.template.points @ linear.transpose(0, 2, 1) + matrices[:, None, :3, 3]
        normals = self.template.normals @ np.linalg.inv(linear)
        normals /= np.sqrt(np.einsum("kni,kni->kn", normals, normals))[..., None]
        points_out[self.first:self.stop] = placed.reshape(-1, 3)
        normals_out[self.first:self.stop] = normals.reshape(-1, 3)

    def triangles(self) -> NDArray[np.int64]:
        n = len(self.template.points)
        offsets = self.first + n * np.arange(self.count)
        return (self.template.triangles[None, :, :] + offsets[:, None, None]).reshape(-1, 3)
