"""Reads .vtu/.vtk files with the VTK library and prints, one line per file:
path points cells tetra_cells positive_tets field_sum level_sum error_max xmin ymax
(field = the first point-data array). Used by test_vtk_writers to check that
VTK itself accepts what tetlod writes."""
import sys

import vtk
from vtk.util.numpy_support import vtk_to_numpy


def read(path):
    if path.endswith(".vtu"):
        reader = vtk.vtkXMLUnstructuredGridReader()
    else:
        reader = vtk.vtkUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    return reader.GetOutput()


def main():
    for path in sys.argv[1:]:
        grid = read(path)
        points = grid.GetNumberOfPoints()
        cells = grid.GetNumberOfCells()
        tetras = sum(1 for c in range(cells) if grid.GetCellType(c) == vtk.VTK_TETRA)
        positive = 0
        for c in range(cells):
            ids = grid.GetCell(c).GetPointIds()
            p = [grid.GetPoint(ids.GetId(i)) for i in range(4)]
            if vtk.vtkTetra.ComputeVolume(*p) > 0:
                positive += 1
        field = vtk_to_numpy(grid.GetPointData().GetArray(0))
        level = vtk_to_numpy(grid.GetCellData().GetArray("level"))
        error = vtk_to_numpy(grid.GetCellData().GetArray("error"))
        bounds = grid.GetBounds()
        print(path, points, cells, tetras, positive, repr(float(field.sum())),
              int(level.astype("int64").sum()), repr(float(error.max())),
              repr(bounds[0]), repr(bounds[3]))


if __name__ == "__main__":
    main()
