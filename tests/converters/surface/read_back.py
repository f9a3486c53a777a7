"""Reads a mesh file with a real third-party reader and prints what it found as
one JSON object, for the C++ tests to compare with what tetlod wrote.

usage: read_back.py LIB FILE     LIB: meshio | vtk

{"points": n, "cells": {"triangle": n, "tetra": n, ...},
 "point_data": {name: sum}, "cell_data": {name: [sum, max]},
 "positive_tets": n, "bounds": [xmin, xmax, ymin, ymax, zmin, zmax]}
Exit 3 when the library is not installed (the caller skips)."""
import json
import sys


def with_meshio(path):
    try:
        import meshio
        import numpy as np
    except ImportError:
        sys.exit(3)
    m = meshio.read(path)
    out = {"points": int(len(m.points)), "cells": {}, "point_data": {}, "cell_data": {}}
    for block in m.cells:
        out["cells"][block.type] = out["cells"].get(block.type, 0) + int(len(block.data))
    for name, a in m.point_data.items():
        out["point_data"][name] = float(np.asarray(a, dtype=float).sum())
    for name, blocks in m.cell_data.items():
        a = np.concatenate([np.asarray(b, dtype=float).ravel() for b in blocks])
        out["cell_data"][name] = [float(a.sum()), float(a.max()) if len(a) else 0.0]
    positive = 0
    for block in m.cells:
        if block.type == "tetra":
            p = m.points[block.data]
            d = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
            positive += int((d > 0).sum())
    out["positive_tets"] = positive
    lo, hi = m.points.min(axis=0), m.points.max(axis=0)
    out["bounds"] = [float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1]), float(lo[2]), float(hi[2])]
    return out


def with_vtk(path):
    try:
        import vtk
        from vtk.util.numpy_support import vtk_to_numpy
    except ImportError:
        sys.exit(3)
    ext = path.rsplit(".", 1)[-1].lower()
    reader = {"ply": vtk.vtkPLYReader, "obj": vtk.vtkOBJReader, "stl": vtk.vtkSTLReader,
              "vtu": vtk.vtkXMLUnstructuredGridReader, "vtk": vtk.vtkUnstructuredGridReader}[ext]()
    if ext == "stl":
        reader.ScalarTagsOff()
    reader.SetFileName(path)
    reader.Update()
    d = reader.GetOutput()
    out = {"points": d.GetNumberOfPoints(), "cells": {}, "point_data": {}, "cell_data": {}}
    tri = 0
    for c in range(d.GetNumberOfCells()):
        if d.GetCellType(c) == vtk.VTK_TRIANGLE:
            tri += 1
    out["cells"]["triangle"] = tri
    for i in range(d.GetPointData().GetNumberOfArrays()):
        a = d.GetPointData().GetArray(i)
        out["point_data"][a.GetName() or "unnamed%d" % i] = float(vtk_to_numpy(a).sum())
    for i in range(d.GetCellData().GetNumberOfArrays()):
        a = vtk_to_numpy(d.GetCellData().GetArray(i)).astype(float)
        out["cell_data"][d.GetCellData().GetArrayName(i) or "unnamed%d" % i] = [float(a.sum()), float(a.max()) if len(a) else 0.0]
    out["bounds"] = list(d.GetBounds())
    return out


def main():
    lib, path = sys.argv[1], sys.argv[2]
    print(json.dumps(with_meshio(path) if lib == "meshio" else with_vtk(path)))


if __name__ == "__main__":
    main()
