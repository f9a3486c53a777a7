// Encoding on every process (ht_distributed.hpp, docs/distributed.md §3.6
// step 3): rows of bricks encoded from their lattice planes into the same
// sections the streaming encoder (ht_stream_encode.cpp) writes, and the file
// laid out from the sizes and checksums of sections encoded elsewhere.
//
// Why the bytes are the same: a chunk's coders read only the lattice of
// spacing 2^t over the brick grown by 2^t (the row's window here, a window
// over the same planes in the streaming encoder's buffer), original values
// and final errors; the window's geometry is the one the streaming encoder
// gives its coders (origin at the window's first plane).
#include <tbb/parallel_for.h>

#include <algorithm>
#include <span>

#include "tetlod/codecs/ht/ht_distributed.hpp"

#include "ht_chunk_geometry.hpp"
#include "ht_chunk_modes.hpp"
#include "ht_container_parts.hpp"

namespace tetlod {

using namespace ht_detail;

namespace {

struct RowSpan {
    int64_t h = 1, side = 1, nrows = 1;
    int64_t lo = 0, hi = 0;    // the row's planes (as the streaming encoder's Rows::row_lo/row_hi)
    int64_t wlo = 0, whi = 0;  // the planes its coders read
};

RowSpan row_span(const Geometry& G, HtBrickRow r) {
    if (r.t < 0 || r.t > G.k) throw Error(ErrorCode::InvalidArgument, "HT row: cycle out of range");
    RowSpan s;
    const int64_t zmax = G.box_max[2];
    s.h = int64_t{1} << r.t;
    s.side = G.side(r.t);
    s.nrows = G.bricks(r.t)[2];
    if (r.row < 0 || r.row >= s.nrows) throw Error(ErrorCode::InvalidArgument, "HT row: row out of range");
    s.lo = r.row * s.side;
    s.hi = r.row + 1 == s.nrows ? zmax : std::min(zmax, (r.row + 1) * s.side - 1);
    s.wlo = std::max<int64_t>(0, s.lo - s.h);
    s.whi = std::min(zmax, s.hi + s.h);
    return s;
}

}  // namespace

std::vector<HtBrickRow> ht_rows_in(const HtDomain& d, int brick_log2, int64_t za, int64_t zb) {
    std::vector<HtBrickRow> out;
    if (za > zb) return out;
    const Geometry G = geometry_of(d, brick_log2);
    for (int t = G.k; t >= 0; --t) {
        const int64_t side = G.side(t), nrows = G.bricks(t)[2];
        for (int64_t row = (std::max<int64_t>(za, 0) + side - 1) / side; row < nrows && row * side <= zb; ++row)
            out.push_back(HtBrickRow{t, row});
    }
    return out;
}

std::array<int64_t, 2> ht_row_window(const HtDomain& d, int brick_log2, HtBrickRow row) {
    const RowSpan s = row_span(geometry_of(d, brick_log2), row);
    return {s.wlo, s.whi};
}

HtRowEncoder::HtRowEncoder(const HtDomain& d, ValueType type, const HtEncodeOptions& o) : d_(d), type_(type), o_(o) {
    o_.progress = nullptr;
}

void HtRowEncoder::encode(HtBrickRow row, const std::byte* values, const float* errors, std::vector<HtSection>& out) {
    const Geometry G = geometry_of(d_, o_.brick_log2);
    const RowSpan s = row_span(G, row);
    const int t = row.t;
    Geometry W = G;
    W.shift = t;
    W.origin = {0, 0, s.wlo};
    W.nx = (G.box_max[0] >> t) + 1;
    W.ny = (G.box_max[1] >> t) + 1;
    const int64_t plane_points = W.nx * W.ny;
    const int64_t planes = ((s.whi - s.wlo) >> t) + 1;
    const bool with_errors = t < d_.k;
    if (with_errors && !errors) throw Error(ErrorCode::InvalidArgument, "HtRowEncoder: the row's errors are missing");
    const std::span<const float> e(errors, with_errors ? std::size_t(planes * plane_points) : 0);

    // The row's chunks: bricks row * per_row .. (row + 1) * per_row - 1 of cycle t.
    const auto nb = G.bricks(t);
    const std::size_t per_row = std::size_t(nb[0] * nb[1]);
    const int m = o_.error_mantissa_bits;
    const ChunkModeChoice choice = chunk_mode_choice(o_);
    std::vector<CodedSection> fs(per_row), es(per_row);
    dispatch_value_type(type_, [&](auto tag) {
        using T = decltype(tag);
        const T* v = reinterpret_cast<const T*>(values);
        // A chunk's field and errors are two tasks (as the streaming encoder).
        tbb::parallel_for(
            std::size_t(0), 2 * per_row,
            [&](std::size_t k) {
                const std::size_t j = k / 2;
                HtChunk c;
                c.cycle = t;
                c.brick = uint32_t(std::size_t(row.row) * per_row + j);
                c.box = G.brick_box(t, c.brick);
                c.points = G.count_points(t, c.box);
                c.diamonds = t == G.k ? 0 : c.points;
                if (k % 2 == 0) fs[j] = encode_field_chunk_v3<T>(W, v, c, choice);
                else es[j] = encode_error_chunk_v3<T>(W, v, e, c, m, choice);
            },
            tbb::simple_partitioner());
    });
    if (with_errors) {
        // As the streaming encoder: the errors at the centres of cycle t of
        // the row's own planes.
        const int64_t p0 = (s.lo - s.wlo + s.h - 1) >> t, p1 = (s.hi - s.wlo) >> t;
        std::vector<ErrorSummary> sums(std::size_t(p1 - p0 + 1), ErrorSummary(m));
        tbb::parallel_for(p0, p1 + 1, [&](int64_t p) {
            const float* plane = errors + std::size_t(p * plane_points);
            ErrorSummary& sum = sums[std::size_t(p - p0)];
            const bool z_even = (((s.wlo >> t) + p) & 1) == 0;
            for (int64_t yi = 0; yi < W.ny; ++yi) {
                const float* r = plane + yi * W.nx;
                const int64_t step = z_even && (yi & 1) == 0 ? 2 : 1;
                for (int64_t xi = step - 1; xi < W.nx; xi += step) sum.add(r[xi]);
            }
        });
        for (const ErrorSummary& sum : sums) {
            stats_.raw_max = std::max(stats_.raw_max, sum.raw_max());
            stats_.always_split += sum.always_split;
        }
    }
    for (std::size_t j = 0; j < per_row; ++j) {
        const uint32_t brick = uint32_t(std::size_t(row.row) * per_row + j);
        for (int which = 0; which < 2; ++which) {
            CodedSection& c = which == 0 ? fs[j] : es[j];
            HtSection sec;
            sec.type = which == 0 ? tlod::kSectionHtField : tlod::kSectionHtErrors;
            sec.flags = c.flags;
            sec.cycle = uint32_t(t);
            sec.brick = brick;
            sec.raw_size = c.raw_size;
            sec.checksum = tlod::checksum64(c.bytes);
            sec.bytes = std::move(c.bytes);
            out.push_back(std::move(sec));
        }
    }
}

HtContainerLayout ht_distributed_layout(const HtDomain& d, tlod::Metadata meta, HtRowEncoder::ErrorStats stats,
                                        const HtEncodeOptions& o, const std::vector<HtSectionEntry>& entries) {
    const Geometry G = geometry_of(d, o.brick_log2);
    const std::vector<HtChunk> chunks = chunk_list(G);
    // First index in chunks of each cycle (file order: cycle k first).
    std::vector<std::size_t> first(std::size_t(d.k) + 1, 0);
    for (std::size_t i = chunks.size(); i-- > 0;) first[std::size_t(chunks[i].cycle)] = i;
    // Slot of each section in the streaming encoder's order: per chunk, field then errors.
    std::vector<int64_t> entry_of(chunks.size() * 2, -1);
    for (std::size_t i = 0; i < entries.size(); ++i) {
        const HtSectionEntry& e = entries[i];
        const int which = e.type == tlod::kSectionHtField ? 0 : e.type == tlod::kSectionHtErrors ? 1 : -1;
        if (which < 0 || e.cycle > uint32_t(d.k))
            throw Error(ErrorCode::InvalidArgument, "HT layout: not an HT chunk section");
        const auto nb = G.bricks(int(e.cycle));
        if (e.brick >= uint64_t(nb[0] * nb[1] * nb[2])) throw Error(ErrorCode::InvalidArgument, "HT layout: brick out of range");
        const std::size_t slot = (first[e.cycle] + e.brick) * 2 + std::size_t(which);
        if (entry_of[slot] >= 0) throw Error(ErrorCode::InvalidArgument, "HT layout: a section given twice");
        entry_of[slot] = int64_t(i);
    }
    for (int64_t e : entry_of)
        if (e < 0) throw Error(ErrorCode::InvalidArgument, "HT layout: a chunk section is missing");

    ErrorSummary summary(o.error_mantissa_bits);
    summary.merge_raw(stats.raw_max, stats.always_split);
    tlod::ContainerWriter w;
    add_ht_leading_sections(w, d, std::move(meta), summary, o);
    for (int64_t e : entry_of) {
        const HtSectionEntry& s = entries[std::size_t(e)];
        w.add_external(s.type, s.flags, s.cycle, s.brick, s.stored_size, s.raw_size, s.checksum);
    }
    HtContainerLayout layout;
    layout.head = w.leading_bytes();
    const std::vector<uint64_t> offsets = w.section_offsets();
    const std::size_t leading = offsets.size() - entry_of.size();
    layout.offsets.resize(entries.size());
    for (std::size_t slot = 0; slot < entry_of.size(); ++slot)
        layout.offsets[std::size_t(entry_of[slot])] = offsets[leading + slot];
    if (!entry_of.empty() && layout.head.size() != offsets[leading])
        throw Error(ErrorCode::InvalidArgument, "HT layout: the leading sections are not contiguous");
    layout.file_size = w.file_size();
    return layout;
}

}  // namespace tetlod
