#pragma once
// Helpers for the isosurface and writer tests: analytic volumes meshed through
// the HT, and running the third-party readers (read_back.py, gmsh).
#include <array>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include "tetlod/models/ht/ht_model.hpp"
#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/volume.hpp"

namespace tetlod::test {

/// f = r^2 - |p - c|^2 on an n^3 f64 grid (inside the ball: f >= 0).
inline Volume ball_volume(int n, std::array<double, 3> c, double r) {
    Volume v = Volume::allocate(Dims{n, n, n}, ValueType::F64);
    for (int z = 0; z < n; ++z)
        for (int y = 0; y < n; ++y)
            for (int x = 0; x < n; ++x) {
                const double dx = x - c[0], dy = y - c[1], dz = z - c[2];
                v.set_value(v.dims.index(x, y, z), r * r - (dx * dx + dy * dy + dz * dz));
            }
    return v;
}

inline TetMesh full_mesh(Volume v) {
    const HtModel m = HtModel::build(std::move(v));
    LodQuery q;
    q.full = true;
    return m.extract(q);
}

/// Runs a shell command; its stdout, or nullopt with the exit status in *status.
inline std::optional<std::string> run(const std::string& cmd, int* status = nullptr) {
    std::FILE* p = popen(cmd.c_str(), "r");
    if (!p) return std::nullopt;
    std::string out;
    char buf[4096];
    std::size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
    const int rc = pclose(p);
    const int code = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
    if (status) *status = code;
    if (code != 0) return std::nullopt;
    return out;
}

/// Why `lib` (meshio, vtk) cannot be used, or empty when it can.
inline std::string python_reader_missing(const std::string& lib) {
    int status = 0;
    if (!run("/usr/bin/python3 -c 'import " + lib + "' 2>/dev/null", &status))
        return "/usr/bin/python3 cannot import " + lib + " (install python3-" +
               (lib == "vtk" ? std::string("vtk9") : lib) + ")";
    return "";
}

inline std::string gmsh_missing() {
    if (!run("command -v gmsh >/dev/null 2>&1")) return "gmsh is not installed (apt-get install gmsh)";
    return "";
}

}  // namespace tetlod::test
