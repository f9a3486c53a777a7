"""Peer for `tetlod extract VOLUME out.vtu --full`: VTK tetrahedralizes the same
u8 volume (vtkDataSetTriangleFilter, 5 tets per voxel) and writes it with
vtkXMLUnstructuredGridWriter (zlib). Prints tets and seconds; run it beside
`/usr/bin/time tetlod extract VOLUME out.vtu --full` and compare tets per second.

    /usr/bin/python3 bench/peer_vtk_full_mesh.py bucky_128x128x128_uint8.raw 128 128 128
"""
import sys
import time

import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk


def main():
    path, nx, ny, nz = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    out = sys.argv[5] if len(sys.argv) > 5 else "peer_vtk.vtu"
    values = np.fromfile(path, dtype=np.uint8)
    t0 = time.time()
    image = vtk.vtkImageData()
    image.SetDimensions(nx, ny, nz)
    array = numpy_to_vtk(values, deep=1)
    array.SetName("value")
    image.GetPointData().SetScalars(array)
    tetra = vtk.vtkDataSetTriangleFilter()
    tetra.SetInputData(image)
    tetra.Update()
    t1 = time.time()
    writer = vtk.vtkXMLUnstructuredGridWriter()
    writer.SetFileName(out)
    writer.SetInputData(tetra.GetOutput())
    writer.SetCompressorTypeToZLib()
    writer.Write()
    t2 = time.time()
    tets = tetra.GetOutput().GetNumberOfCells()
    print(f"VTK: {tets} tets, tetrahedralize {t1 - t0:.2f} s, write {t2 - t1:.2f} s, "
          f"{tets / (t2 - t0) / 1e6:.2f} M tets/s")


if __name__ == "__main__":
    main()
