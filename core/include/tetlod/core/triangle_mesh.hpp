#pragma once
// A triangle surface in world coordinates: the output of isosurface extraction
// (models/isosurface.hpp) and the input of the surface writers
// (converters/surface). Lives in core, beside TetMesh, so writers need not depend
// on the codec.
#include <array>
#include <cstdint>
#include <vector>

namespace tetlod {

struct TriangleMesh {
    /// Vertex positions, world coordinates.
    std::vector<std::array<double, 3>> points;
    /// Per vertex: unit normal (empty, or one per point). See the producer for
    /// which side it faces (isosurfaces: towards decreasing field).
    std::vector<std::array<double, 3>> normals;
    /// Per vertex: gradient of the field, world units (empty, or one per point).
    std::vector<std::array<double, 3>> gradients;
    /// Triangles, counter-clockwise seen from the side the normals face.
    std::vector<std::array<uint32_t, 3>> faces;
    /// Per face: error bound of the tet it was cut from (empty, or one per face).
    std::vector<float> face_error;
    /// Per face: index of the isovalue (surface) it belongs to (empty, or one per face).
    std::vector<uint16_t> face_surface;

    std::size_t vertex_count() const { return points.size(); }
    std::size_t face_count() const { return faces.size(); }
};

}  // namespace tetlod
