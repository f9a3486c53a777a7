"""tetlod: multiresolution tetrahedral meshes (HT, MT) of volume data.

    import tetlod
    tetlod.convert("bucky_32x32x32_uint8.raw", "bucky.tlod", mt=True)
    mesh = tetlod.extract("bucky.tlod", error="1%")      # a Mesh
    mesh.points, mesh.tets, mesh.values, mesh.error       # numpy views, no copies
    mesh.write("bucky.vtu")

Failures raise tetlod.Error (a RuntimeError) naming the file and the problem.
"""
from ._tetlod import *  # noqa: F401,F403
from ._tetlod import Error, Mesh, Model, Surface, __version__, format_version  # noqa: F401
