#pragma once
// A mesh handed over in parts, so that a query's output never has to be held
// whole: first the vertices (all of them, since any tet may use any), then the
// tets in order, batch by batch. Streaming writers implement it; so does
// TetMeshCollector, which assembles an ordinary TetMesh.
#include <array>
#include <cstdint>
#include <span>
#include <string>

#include "tetlod/core/error.hpp"

#include "tetlod/core/tet_mesh.hpp"

namespace tetlod {

class TetMeshSink {
public:
    virtual ~TetMeshSink() = default;
    /// Once, first. `vertices` carries geometry, field name, value type, points
    /// and values; its tet arrays are ignored. `tet_count` tets will follow.
    virtual void begin(const TetMesh& vertices, uint64_t tet_count) = 0;
    /// The next tets, with their level and error (same lengths).
    virtual void add(std::span<const std::array<uint32_t, 4>> tets, std::span<const uint8_t> level,
                     std::span<const float> error) = 0;
    /// Once, last: completes the output (a file is committed here, atomically).
    /// Throws when fewer or more tets came than begin announced.
    virtual void finish() = 0;
};

/// What every streaming writer checks of the parts it is given: tets use
/// existing vertices, no more tets come than begin() announced and exactly
/// that many by finish(), and level (and error) come for every tet or for none
/// (a TetMesh may lack them). Each check throws InvalidArgument "<context>: ...".
class StreamedTetChecks {
public:
    void begin(std::string context, std::size_t points, uint64_t announced) {
        context_ = std::move(context);
        points_ = points;
        announced_ = announced;
    }
    void batch(std::span<const std::array<uint32_t, 4>> tets, std::size_t levels, std::size_t errors);
    void finish() const;
    uint64_t added() const { return added_; }  // before the batch being checked: its first tet's index
    bool level() const { return level_ == 1; }
    bool error() const { return error_ == 1; }

private:
    void presence(std::size_t tets, std::size_t n, int& has) const;
    std::string context_;
    std::size_t points_ = 0;
    uint64_t announced_ = 0, added_ = 0;
    int level_ = -1, error_ = -1;  // unknown until a tet comes
};

/// Collects the parts into a TetMesh.
class TetMeshCollector final : public TetMeshSink {
public:
    void begin(const TetMesh& vertices, uint64_t tet_count) override {
        mesh = vertices;
        mesh.tets.clear();
        mesh.level.clear();
        mesh.error.clear();
        mesh.tets.reserve(tet_count);
        mesh.level.reserve(tet_count);
        mesh.error.reserve(tet_count);
    }
    void add(std::span<const std::array<uint32_t, 4>> tets, std::span<const uint8_t> level,
             std::span<const float> error) override {
        mesh.tets.insert(mesh.tets.end(), tets.begin(), tets.end());
        mesh.level.insert(mesh.level.end(), level.begin(), level.end());
        mesh.error.insert(mesh.error.end(), error.begin(), error.end());
    }
    void finish() override {}
    TetMesh mesh;
};

/// Passes the parts on, counting them.
class TetMeshCounter final : public TetMeshSink {
public:
    explicit TetMeshCounter(TetMeshSink& to) : to_(to) {}
    void begin(const TetMesh& v, uint64_t n) override {
        vertices = v.points.size();
        to_.begin(v, n);
    }
    void add(std::span<const std::array<uint32_t, 4>> t, std::span<const uint8_t> l,
             std::span<const float> e) override {
        tets += t.size();
        to_.add(t, l, e);
    }
    void finish() override { to_.finish(); }
    uint64_t vertices = 0, tets = 0;

private:
    TetMeshSink& to_;
};

/// Hands a whole mesh to a sink (begin, one add, finish).
inline void send_mesh(const TetMesh& mesh, TetMeshSink& sink) {
    sink.begin(mesh, mesh.tets.size());
    sink.add(mesh.tets, mesh.level, mesh.error);
    sink.finish();
}

}  // namespace tetlod
