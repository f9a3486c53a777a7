#pragma once
// The pieces of the Python module, one file per concern; module.cpp registers
// them in order (errors first: every later binding may raise tetlod.Error).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

namespace tetlod::python {

void bind_errors(pybind11::module_& m);     // errors.cpp: tetlod.Error
void bind_meshes(pybind11::module_& m);     // meshes.cpp: Mesh, Surface, write_mesh/surface
void bind_volumes(pybind11::module_& m);    // volumes.cpp: read/write volumes as numpy arrays
void bind_containers(pybind11::module_& m); // containers.cpp: info, models, convert, decode, verify
void bind_models(pybind11::module_& m);     // models.cpp: open, extract, isosurface, stats

}  // namespace tetlod::python
