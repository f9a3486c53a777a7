// Decoding chosen chunks into a field and error array (shared by the whole
// decode and the lazy extraction).
#include "ht_chunk_decoder.hpp"

#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <exception>

#include "ht_chunk_modes.hpp"
#include "ht_residual_v1.hpp"
#include "tetlod/codecs/lossy_field.hpp"

namespace tetlod::ht_detail {

/// Adds to `want` every chunk the wanted ones depend on: per cycle, the coarser
/// chunks meeting the wanted chunks' boxes grown by the predictor reach (2^t
/// at cycle t, spec §6.3). `want` is indexed like L.chunks (file order).
void add_dependencies(const HtLayout& L, std::vector<char>& want) {
    // Wanted boxes of the current cycle, grown as we go coarser.
    std::vector<std::array<int64_t, 6>> region;
    std::size_t i = L.chunks.size();
    while (i > 0) {  // from the finest cycle (end of the list) to the coarsest
        std::size_t b = i;
        while (b > 0 && L.chunks[b - 1].cycle == L.chunks[i - 1].cycle) --b;
        const int t = L.chunks[b].cycle;
        for (std::size_t j = b; j < i; ++j) {
            const HtChunk& c = L.chunks[j];
            if (!want[j])
                for (const auto& g : region) {
                    bool meet = true;
                    for (int a = 0; a < 3; ++a)
                        meet = meet && c.box[a] <= g[3 + a] && g[a] <= c.box[3 + a];
                    if (meet) {
                        want[j] = 1;
                        break;
                    }
                }
        }
        const int64_t h = int64_t{1} << t;
        for (auto& g : region)
            for (int a = 0; a < 3; ++a) g[a] -= h, g[3 + a] += h;
        for (std::size_t j = b; j < i; ++j) {
            if (!want[j]) continue;
            auto g = L.chunks[j].box;
            for (int a = 0; a < 3; ++a) g[a] -= h, g[3 + a] += h;
            region.push_back(g);
        }
        i = b;
    }
}

namespace {

Failure decode_chunk_field(const tlod::ContainerReader& r, const HtLayout& L, const HtChunk& c, const Geometry& G,
                           ValueType type, void* field, std::vector<std::byte>& field_stored);
Failure decode_chunk_errors_stored(const tlod::ContainerReader& r, const HtLayout& L, const HtChunk& c,
                                   const Geometry& G, ValueType type, const void* field, float* errors,
                                   std::vector<std::byte>& error_stored);

}  // namespace

/// Spec §5.1 (lossy files): the bound of every diamond of the chunk is its
/// stored bound plus E, so queries honour their bound against the original.
Failure decode_chunk_errors(const tlod::ContainerReader& r, const HtLayout& L, const HtChunk& c, const Geometry& G,
                            ValueType type, const void* field, float* errors, std::vector<std::byte>& error_stored) {
    Failure f = decode_chunk_errors_stored(r, L, c, G, type, field, errors, error_stored);
    if (f.code != ErrorCode::Ok || L.max_error <= 0 || c.diamonds == 0) return f;
    G.for_each_point(c.cycle, c.box, [&](int64_t x, int64_t y, int64_t z) {
        float& e = errors[G.index(x, y, z)];
        e = bound_against_original(e, L.max_error);
    });
    return f;
}

Failure decode_chunk_sections(const tlod::ContainerReader& r, const HtLayout& L, const HtChunk& c, const Geometry& G,
                              ValueType type, void* field, float* errors, std::vector<std::byte>& field_stored,
                              std::vector<std::byte>& error_stored) {
    Failure f = decode_chunk_field(r, L, c, G, type, field, field_stored);
    if (f.code != ErrorCode::Ok || !errors) return f;
    return decode_chunk_errors(r, L, c, G, type, field, errors, error_stored);
}

namespace {

std::string section_context(const tlod::ContainerReader& r, uint32_t section) {
    return r.name() + ": section " + std::to_string(section) + ": ";
}

Expected<std::vector<std::byte>> unpack(std::vector<std::byte>& stored, const tlod::SectionInfo& si) {
    if (!(si.flags & tlod::kSectionZstd)) return std::move(stored);
    return tlod::zstd_decompress(stored, si.raw_size);
}

Failure decode_chunk_field(const tlod::ContainerReader& r, const HtLayout& L, const HtChunk& c, const Geometry& G,
                           ValueType type, void* field, std::vector<std::byte>& field_stored) {
    const tlod::SectionInfo& fsi = r.sections()[c.field_section];
    auto raw = unpack(field_stored, fsi);
    if (!raw) return with_context(section_context(r, c.field_section), raw.failure());
    if (L.residual_coding == kResidualChunkModes) {
        const std::string bad = dispatch_value_type(type, [&](auto tv) {
            using T = decltype(tv);
            return decode_field_chunk_v3<T>(G, static_cast<T*>(field), c, tlod::section_mode(fsi.flags), *raw,
                                            lattice_step<T>(L.max_error));
        });
        if (!bad.empty()) return fail(ErrorCode::CorruptData, section_context(r, c.field_section) + bad);
        return Failure{ErrorCode::Ok, {}};
    }
    const bool ok = dispatch_value_type(type, [&](auto tv) {
        using T = decltype(tv);
        if (L.residual_coding == kResidualZigzagPlanes) {
            decode_field_chunk<T>(G, static_cast<T*>(field), c, raw->data());
            return true;
        }
        return decode_field_chunk_v2<T>(G, static_cast<T*>(field), c, *raw);
    });
    if (!ok) return fail(ErrorCode::CorruptData, section_context(r, c.field_section) + "malformed range-coded stream");
    return Failure{ErrorCode::Ok, {}};
}

Failure decode_chunk_errors_stored(const tlod::ContainerReader& r, const HtLayout& L, const HtChunk& c,
                                   const Geometry& G, ValueType type, const void* field, float* errors,
                                   std::vector<std::byte>& error_stored) {
    const int m = L.error_mantissa_bits;
    const tlod::SectionInfo& esi = r.sections()[c.error_section];
    auto er = unpack(error_stored, esi);
    if (!er) return with_context(section_context(r, c.error_section), er.failure());
    if (L.residual_coding == kResidualChunkModes) {
        const std::string bad = dispatch_value_type(type, [&](auto tv) {
            using T = decltype(tv);
            return decode_error_chunk_v3<T>(G, static_cast<const T*>(field), errors, c, m,
                                            tlod::section_mode(esi.flags), *er);
        });
        if (!bad.empty()) return fail(ErrorCode::CorruptData, section_context(r, c.error_section) + bad);
        return Failure{ErrorCode::Ok, {}};
    }
    const bool codes_ok = dispatch_value_type(type, [&](auto tv) {
        using T = decltype(tv);
        const T* v = static_cast<const T*>(field);
        if (L.residual_coding == kResidualZigzagPlanes) return decode_error_chunk<T>(G, v, errors, c, m, er->data());
        return decode_error_chunk_v2<T>(G, v, errors, c, m, *er);
    });
    if (!codes_ok)
        return fail(ErrorCode::CorruptData,
                    section_context(r, c.error_section) + "error code out of range or malformed stream");
    return Failure{ErrorCode::Ok, {}};
}

}  // namespace

/// Decodes the wanted chunks not yet decoded (`done`), cycle by cycle, into
/// `field` / `errors` (errors when non-null). Dependencies must be wanted too.
Expected<uint64_t> decode_chunks(tlod::ContainerReader& r, const HtLayout& L, const std::vector<char>& want,
                                 std::vector<char>& done, Volume& field, ZeroedVector<float>* errors,
                                 const std::function<void(uint64_t, uint64_t)>& progress) {
    const Geometry G = geometry_of(L.domain, L.brick_log2);
    uint64_t decoded = 0, to_decode = 0;
    for (std::size_t j = 0; j < L.chunks.size(); ++j) to_decode += want[j] && !done[j];
    // A cycle's error chunks read the field of that cycle and the coarser ones
    // only, and the next cycle's field chunks write only their own points: so
    // the errors of a cycle decode while the finer fields do. A small volume
    // has one chunk per cycle, which decoded one after another on one core.
    std::vector<std::vector<std::byte>> error_stored(L.chunks.size());
    std::vector<Failure> error_fails(L.chunks.size(), Failure{ErrorCode::Ok, {}});
    std::vector<std::exception_ptr> error_throws(L.chunks.size());
    tbb::task_group pending;
    struct WaitFor {  // every path out waits: the tasks use these arrays
        tbb::task_group& g;
        ~WaitFor() { g.wait(); }
    } wait_for{pending};
    std::size_t i = 0;
    while (i < L.chunks.size()) {
        std::size_t e = i;
        while (e < L.chunks.size() && L.chunks[e].cycle == L.chunks[i].cycle) ++e;
        std::vector<std::size_t> ids;
        for (std::size_t j = i; j < e; ++j)
            if (want[j] && !done[j]) ids.push_back(j);
        std::vector<std::vector<std::byte>> fst(ids.size());
        for (std::size_t j = 0; j < ids.size(); ++j) {
            auto s = r.read_stored(L.chunks[ids[j]].field_section);
            if (!s) return s.failure();
            fst[j] = std::move(*s);
            if (errors) {
                auto s2 = r.read_stored(L.chunks[ids[j]].error_section);
                if (!s2) return s2.failure();
                error_stored[ids[j]] = std::move(*s2);
            }
        }
        std::vector<Failure> fails(ids.size(), Failure{ErrorCode::Ok, {}});
        tbb::parallel_for(std::size_t(0), ids.size(), [&](std::size_t j) {
            fails[j] = decode_chunk_sections(r, L, L.chunks[ids[j]], G, field.type, field.data.data(), nullptr,
                                             fst[j], error_stored[ids[j]]);
        });
        for (const Failure& f : fails)
            if (f.code != ErrorCode::Ok) return f;
        if (errors)
            for (std::size_t id : ids)
                pending.run([&, id] {
                    try {
                        error_fails[id] = decode_chunk_errors(r, L, L.chunks[id], G, field.type, field.data.data(),
                                                              errors->data(), error_stored[id]);
                    } catch (...) {
                        error_throws[id] = std::current_exception();
                    }
                    error_stored[id] = {};
                });
        for (std::size_t j : ids) done[j] = 1;
        decoded += ids.size();
        if (progress) progress(decoded, to_decode);
        i = e;
    }
    pending.wait();
    for (std::size_t j = 0; j < L.chunks.size(); ++j) {  // the first failure in file order
        if (error_throws[j]) std::rethrow_exception(error_throws[j]);
        if (error_fails[j].code != ErrorCode::Ok) return error_fails[j];
    }
    return decoded;
}

Expected<Volume> allocate_decoded(const std::string& name, const HtLayout& L, ZeroedVector<float>* errors) {
    try {
        auto field = capture([&] { return Volume::allocate(L.domain.dims(), L.metadata.type); }, name + ": ");
        if (field && errors) errors->resize(std::size_t(field->count()));  // zero, untouched
        return field;
    } catch (const std::bad_alloc&) {
        return fail(ErrorCode::TooLarge, name + ": cannot allocate the decoded field");
    }
}

void restore_metadata(Volume& field, const tlod::Metadata& md) {
    field.spacing = md.spacing;
    field.origin = md.origin;
    field.field_name = md.field_name();
    field.units = md.units();
    field.metadata = md.user_keys;
}

}  // namespace tetlod::ht_detail
