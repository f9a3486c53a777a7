// The compiled part of the `tetlod` Python package (python/tetlod/__init__.py
// re-exports it). Registers each concern's bindings.
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "tetlod/version.hpp"

PYBIND11_MODULE(_tetlod, m) {
    m.doc() = "tetlod: multiresolution tetrahedral meshes (HT, MT) of volume data";
    m.attr("__version__") = tetlod::library_version();
    m.attr("format_version") = tetlod::format_version();
    tetlod::python::bind_errors(m);
    tetlod::python::bind_meshes(m);
    tetlod::python::bind_volumes(m);
    tetlod::python::bind_containers(m);
    tetlod::python::bind_models(m);
}
