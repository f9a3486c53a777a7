"""Peer of bench_mt: VTK's tetrahedral quadric decimation
(vtkUnstructuredGridQuadricDecimation) of the full-resolution tet mesh of a volume,
at the tet counts of the MT's meshes, and one error evaluator for both meshes.

    /usr/bin/python3 bench/peer_vtk_decimation.py VOLUME.raw NX NY NZ DTYPE MESH.bin [MESH.bin ...]

Each MESH.bin is a mesh of the MT written by bench_mt (grid coordinates): int64
point count, int64 tet count, float64 xyz per point, float64 value per point,
int32 x4 per tet. For each, VTK decimates the full mesh (vtkDataSetTriangleFilter:
5 tets per voxel, as the MT's reference mesh) to the same tet count, and both meshes
are measured the same way, independently of tetlod's code: vtkProbeFilter with a
static cell locator interpolates each mesh at every grid point (linear in the tet
that holds it); error = max |interpolated - volume value| over the points found,
and the points no tet holds are counted as not covered. Prints one line per mesh
and model; "skip: REASON" when VTK or numpy is missing.
"""
import sys
import time

try:
    import numpy as np
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy
except ImportError as e:  # the bench prints the reason and goes on
    print(f"skip: {e}")
    sys.exit(0)

DTYPES = {"u8": np.uint8, "i16": np.int16, "u16": np.uint16, "f32": np.float32}


def image_of(values, nx, ny, nz):
    image = vtk.vtkImageData()
    image.SetDimensions(nx, ny, nz)
    array = numpy_to_vtk(values, deep=1)
    array.SetName("value")
    image.GetPointData().SetScalars(array)
    return image


def grid_of(points, values, tets):
    grid = vtk.vtkUnstructuredGrid()
    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(points, deep=1))
    grid.SetPoints(pts)
    cells = np.hstack([np.full((len(tets), 1), 4, dtype=np.int64), tets.astype(np.int64)]).ravel()
    ids = vtk.vtkIdTypeArray()
    ids.DeepCopy(numpy_to_vtk(cells, deep=1, array_type=vtk.VTK_ID_TYPE))
    ca = vtk.vtkCellArray()
    ca.SetCells(len(tets), ids)
    grid.SetCells(vtk.VTK_TETRA, ca)
    array = numpy_to_vtk(values, deep=1)
    array.SetName("value")
    grid.GetPointData().SetScalars(array)
    return grid


def measure(mesh, image, reference):
    """(max error at the covered grid points, grid points not covered)."""
    name = mesh.GetPointData().GetScalars().GetName()  # VTK's decimation names it "scalars"
    probe = vtk.vtkProbeFilter()
    probe.SetInputData(image)
    probe.SetSourceData(mesh)
    probe.SetCellLocatorPrototype(vtk.vtkStaticCellLocator())
    probe.Update()
    out = probe.GetOutput().GetPointData()
    valid = vtk_to_numpy(out.GetArray(probe.GetValidPointMaskArrayName())).astype(bool)
    got = vtk_to_numpy(out.GetArray(name)).astype(np.float64)
    err = np.abs(got[valid] - reference[valid])
    return (float(err.max()) if err.size else 0.0), int((~valid).sum())


def read_mesh(path):
    with open(path, "rb") as f:
        n, t = np.fromfile(f, dtype=np.int64, count=2)
        points = np.fromfile(f, dtype=np.float64, count=3 * n).reshape(n, 3)
        values = np.fromfile(f, dtype=np.float64, count=n)
        tets = np.fromfile(f, dtype=np.int32, count=4 * t).reshape(t, 4)
    return points, values, tets


def main():
    path, nx, ny, nz, dtype = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
    reference = np.fromfile(path, dtype=DTYPES[dtype]).astype(np.float64)
    image = image_of(reference, nx, ny, nz)
    t0 = time.time()
    tetra = vtk.vtkDataSetTriangleFilter()
    tetra.SetInputData(image)
    tetra.TetrahedraOnlyOn()
    tetra.Update()
    full = tetra.GetOutput()
    print(f"full mesh {full.GetNumberOfCells()} tets (VTK tetrahedralize {time.time() - t0:.2f} s)")
    for mesh_path in sys.argv[6:]:
        points, values, tets = read_mesh(mesh_path)
        mt_err, mt_out = measure(grid_of(points, values, tets), image, reference)
        print(f"MT   {len(tets):9d} tets  {'-':>8}  max_err {mt_err:10.4g}  not_covered {mt_out}")
        t1 = time.time()
        dec = vtk.vtkUnstructuredGridQuadricDecimation()
        dec.SetInputData(full)
        dec.SetScalarsName("value")
        dec.SetNumberOfTetsOutput(len(tets))
        dec.Update()
        seconds = time.time() - t1
        out = dec.GetOutput()
        vtk_err, vtk_out = measure(out, image, reference)
        print(f"VTK  {out.GetNumberOfCells():9d} tets  {seconds:7.2f}s  max_err {vtk_err:10.4g}  not_covered {vtk_out}"
              f"  (MT/VTK error {mt_err / vtk_err if vtk_err else float('nan'):.3f})")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
