// Out-of-core HT conversion: a volume read plane by plane becomes the same
// container bytes as the in-memory encoder writes (ht_encode.cpp).
//
// Two passes over the planes:
//  1. scan: the value range (METADATA, the float error slack), finiteness, and
//     the field on the coarse lattice the error sweep needs (HtErrorSweep).
//  2. sweep: slabs of S planes in a window reaching HtErrorSweep::kReach
//     further on each side. Each slab's planes feed, per cycle t, a buffer of
//     the lattice of spacing 2^t over the planes of the current row of bricks
//     (grown by 2^t, as a chunk's coders read); the sweep writes the errors
//     of its centres there. Once the sweep has passed a row's last plane plus
//     2^t, the row's chunks are encoded (in parallel, in that window) and
//     their bytes spilled to a temporary file beside the output.
// The file is then assembled in the container's order (coarse cycles first),
// copying the chunk bytes from the spill.
//
// Memory: the window (S + 2 * kReach planes), the row buffers (about
// 2^(brick_log2 + 1) + 3 + S planes of value and float error for cycle 0, a
// quarter of that for cycle 1, ...) and the sweep's coarse state.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstring>

#include "tetlod/codecs/ht/ht_distributed.hpp"

#include "ht_chunk_geometry.hpp"
#include "ht_container_parts.hpp"
#include "ht_chunk_modes.hpp"
#include "tetlod/core/huge_page_allocator.hpp"
#include "tetlod/models/ht/ht_error_sweep.hpp"

namespace tetlod {

using namespace ht_detail;

namespace {

constexpr int64_t kReach = HtErrorSweep::kReach;
/// Memory kept back from the budget for what the plan does not count
/// (program, thread stacks, allocator slack, the coders' scratch).
constexpr std::size_t kUnplannedBytes = std::size_t{48} << 20;

/// Planes of the data box B: the source's planes, extended to the cube by
/// repeating the nearest sample when padding (as HtModel::build pads).
class BoxPlanes {
public:
    BoxPlanes(VolumePlanes& src, const HtDomain& d)
        : src_(src), sd_(src.header().dims), vs_(value_size(src.header().type)),
          bx_(int64_t(d.box_max[0]) + 1), by_(int64_t(d.box_max[1]) + 1) {}

    std::size_t plane_bytes() const { return std::size_t(bx_ * by_) * vs_; }

    void read(int64_t z0, int64_t n, std::byte* dst) {
        if (bx_ == sd_.x && by_ == sd_.y && z0 + n <= sd_.z) {
            src_.read(z0, n, dst);
            return;
        }
        source_plane_.resize(std::size_t(sd_.x * sd_.y) * vs_);
        for (int64_t i = 0; i < n; ++i) {
            src_.read(std::min(z0 + i, sd_.z - 1), 1, source_plane_.data());
            std::byte* out = dst + std::size_t(i) * plane_bytes();
            for (int64_t y = 0; y < by_; ++y) {
                const std::byte* row = source_plane_.data() + std::size_t(std::min(y, sd_.y - 1) * sd_.x) * vs_;
                std::byte* o = out + std::size_t(y * bx_) * vs_;
                std::memcpy(o, row, std::size_t(sd_.x) * vs_);
                for (int64_t x = sd_.x; x < bx_; ++x)
                    std::memcpy(o + std::size_t(x) * vs_, row + std::size_t(sd_.x - 1) * vs_, vs_);
            }
        }
    }

private:
    VolumePlanes& src_;
    Dims sd_;
    std::size_t vs_;
    int64_t bx_, by_;
    std::vector<std::byte> source_plane_;
};

/// Pass 1 over planes zfrom..zto of B: the range and finiteness of the
/// source's samples there (`any`: some sample seen) and the coarse lattice's
/// points of those planes (the rest of `coarse` is zero).
template <class T>
std::vector<std::byte> scan_box(BoxPlanes& planes_, const HtDomain& d_, const Geometry& G_, const Dims sd,
                            int64_t zfrom, int64_t zto, const HtStreamEncodeOptions& o_, int64_t zmax_,
                            std::array<double, 2>& range, bool& any_out) {
    const Dims cd = HtErrorSweep::coarse_dims(d_);
    std::vector<std::byte> coarse(std::size_t(cd.count()) * sizeof(T));
    std::vector<T> buf;
    // Up to 32 MiB of planes a read, but no more planes than the box has: the
    // buffer is zero-filled, and 32 MiB of it was 3% of a small volume's encode.
    const int64_t per = std::clamp<int64_t>(int64_t((std::size_t{32} << 20) / planes_.plane_bytes()), 1,
                                            std::max<int64_t>(1, zto - zfrom + 1));
    buf.resize(std::size_t(per) * std::size_t(G_.nx * G_.ny));
    bool any = false;
    T lo{}, hi{};
    for (int64_t z0 = zfrom; z0 <= zto; z0 += per) {
        const int64_t n = std::min(per, zto + 1 - z0);
        planes_.read(z0, n, reinterpret_cast<std::byte*>(buf.data()));
        // Range and finiteness over the source's samples, plane by plane in
        // parallel, combined in plane order (the first minimum and the first
        // non-finite value are those a scan in file order finds).
        struct PlaneScan {
            bool any = false;
            T lo{}, hi{};
            int64_t bad_x = -1, bad_y = -1;
        };
        std::vector<PlaneScan> scans(static_cast<std::size_t>(n));
        tbb::parallel_for(int64_t(0), n, [&](int64_t i) {
            if (z0 + i >= sd.z) return;
            PlaneScan& ps = scans[std::size_t(i)];
            const T* plane = buf.data() + std::size_t(i * G_.nx * G_.ny);
            for (int64_t y = 0; y < sd.y; ++y) {
                const T* row = plane + y * G_.nx;
                if constexpr (std::is_integral_v<T>) {
                    // Integers: the extremes do not depend on the visiting
                    // order, so the row reduces in a loop the compiler
                    // vectorizes (the per-value loop below cost ~1 ns a point).
                    T rlo = row[0], rhi = row[0];
                    for (int64_t x = 1; x < sd.x; ++x) {
                        rlo = std::min(rlo, row[x]);
                        rhi = std::max(rhi, row[x]);
                    }
                    if (!ps.any) ps.lo = rlo, ps.hi = rhi, ps.any = true;
                    ps.lo = std::min(ps.lo, rlo);
                    ps.hi = std::max(ps.hi, rhi);
                    continue;
                }
                for (int64_t x = 0; x < sd.x; ++x) {
                    const T v = row[x];
                    if constexpr (std::is_floating_point_v<T>) {
                        if (!std::isfinite(v)) {
                            ps.bad_x = x;
                            ps.bad_y = y;
                            return;
                        }
                    }
                    if (!ps.any) ps.lo = ps.hi = v, ps.any = true;
                    ps.lo = v < ps.lo ? v : ps.lo;
                    ps.hi = v > ps.hi ? v : ps.hi;
                }
            }
        });
        for (int64_t i = 0; i < n; ++i) {
            const PlaneScan& ps = scans[std::size_t(i)];
            if (ps.bad_x >= 0) {
                const T* plane = buf.data() + std::size_t(i * G_.nx * G_.ny);
                throw Error(ErrorCode::CorruptData,
                            "the volume holds a non-finite value (" +
                                std::to_string(double(plane[ps.bad_y * G_.nx + ps.bad_x])) + ") at (" +
                                std::to_string(ps.bad_x) + "," + std::to_string(ps.bad_y) + "," +
                                std::to_string(z0 + i) + "); the HT needs finite values everywhere");
            }
            if (!ps.any) continue;
            if (!any) lo = ps.lo, hi = ps.hi, any = true;
            lo = ps.lo < lo ? ps.lo : lo;
            hi = ps.hi > hi ? ps.hi : hi;
        }
        for (int64_t i = 0; i < n; ++i) {
            const int64_t z = z0 + i;
            const T* plane = buf.data() + std::size_t(i * G_.nx * G_.ny);
            constexpr int s = HtErrorSweep::kCoarseShift;
            if ((z & ((int64_t{1} << s) - 1)) != 0) continue;
            T* out = reinterpret_cast<T*>(coarse.data()) + std::size_t((z >> s) * cd.y * cd.x);
            for (int64_t y = 0; y < G_.ny; y += int64_t{1} << s)
                for (int64_t x = 0; x < G_.nx; x += int64_t{1} << s)
                    out[(y >> s) * cd.x + (x >> s)] = plane[y * G_.nx + x];
        }
        if (o_.progress) o_.progress("scan", uint64_t(z0 + n), uint64_t(zmax_ + 1));
    }
    range = {double(lo), double(hi)};
    any_out = any;
    return coarse;
}


/// Where one chunk's two sections lie in the spill file.
struct SpilledChunk {
    uint64_t field_offset = 0, field_size = 0, field_checksum = 0, field_raw = 0;
    uint64_t error_offset = 0, error_size = 0, error_checksum = 0, error_raw = 0;
    uint32_t field_flags = 0, error_flags = 0;
};

template <class T>
class StreamEncoder final : public HtErrorPlaneSink {
public:
    StreamEncoder(VolumePlanes& source, const HtDomain& d, const HtStreamEncodeOptions& o, const std::string& path)
        : d_(d), o_(o), m_(o.encode.error_mantissa_bits), planes_(source, d),
          G_(geometry_of(d, o.encode.brick_log2)), chunks_(chunk_list(G_)), path_(path), spill_(path) {
        zmax_ = d.box_max[2];
        // First index in chunks_ of each cycle (file order: cycle k first).
        first_.assign(std::size_t(d.k) + 1, 0);
        for (std::size_t i = chunks_.size(); i-- > 0;) first_[std::size_t(chunks_[i].cycle)] = i;
        spilled_.resize(chunks_.size());
    }

    HtStreamEncodeSummary run(tlod::Metadata meta) {
        HtStreamEncodeSummary summary;
        summary.domain = d_;
        if (o_.errors) {
            summary.range = o_.errors->range();
            summary.slab_planes = int(plan_slab(0, summary.planned_bytes));
            summary.chunks = chunks_.size();
            encode_all(nullptr, summary.slab_planes);
        } else {
            std::vector<std::byte> coarse = scan(summary.range);
            HtErrorSweep sweep(d_, meta.type, summary.range, std::move(coarse));
            summary.slab_planes = int(plan_slab(sweep.memory_bytes(), summary.planned_bytes));
            summary.chunks = chunks_.size();
            encode_all(&sweep, summary.slab_planes);
        }
        meta.value_range = summary.range;
        assemble(meta);
        return summary;
    }

    float* error_plane(int t, int64_t z) override {
        Rows& r = rows_[std::size_t(t)];
        const int64_t p = (z - r.wlo) >> t;
        if (z < r.wlo || p >= r.cap_planes || r.errors.empty())
            throw Error(ErrorCode::InvalidArgument, "HT streaming encoder: error plane outside its window");
        return r.errors.data() + std::size_t(p * r.plane_points);
    }

private:
    /// Cycle t's buffer: the lattice of spacing 2^t on planes wlo, wlo + 2^t, ...
    /// covering the current row of bricks grown by 2^t and what later slabs added.
    struct Rows {
        int t = 0;
        int64_t h = 1, side = 1;
        int64_t row = 0, nrows = 0;
        int64_t nx = 0, ny = 0, plane_points = 0, cap_planes = 0;
        int64_t wlo = 0;
        HugePageVector<T> values;
        HugePageVector<float> errors;  // cycles with diamonds only
        Geometry window;            // the coders' view of the buffer

        int64_t row_lo() const { return row * side; }
        /// The last row also holds plane zmax when zmax is a multiple of the side
        /// (bricks are closed boxes: the last one's far face is that plane).
        int64_t row_hi(int64_t zmax) const { return row + 1 == nrows ? zmax : std::min(zmax, (row + 1) * side - 1); }
    };

    // ---- pass 1 ----
    std::vector<std::byte> scan(std::array<double, 2>& range) {
        bool any = false;
        return scan_box<T>(planes_.box(), d_, G_, planes_.source_dims(), 0, zmax_, o_, zmax_, range, any);
    }

    // ---- planning ----
    void set_up_rows(int64_t S) {
        rows_.assign(std::size_t(d_.k) + 1, Rows{});
        for (int t = 0; t <= d_.k; ++t) {
            Rows& r = rows_[std::size_t(t)];
            r.t = t;
            r.h = int64_t{1} << t;
            r.side = G_.side(t);
            r.nrows = G_.bricks(t)[2];
            r.nx = (G_.box_max[0] >> t) + 1;
            r.ny = (G_.box_max[1] >> t) + 1;
            r.plane_points = r.nx * r.ny;
            // Planes held: the row grown by h on both sides, plus the slab
            // that may arrive before the row can be encoded.
            r.cap_planes = std::min((zmax_ >> t) + 1, r.side / r.h + 3 + (S + r.h - 1) / r.h);
        }
    }

    std::size_t planned_bytes(int64_t S, std::size_t sweep_bytes) {
        set_up_rows(S);
        std::size_t b = std::size_t(S + 2 * kReach) * planes_.plane_bytes();  // window
        for (const Rows& r : rows_) {
            const std::size_t per_point = sizeof(T) + (r.t < d_.k ? sizeof(float) : 0);
            b += std::size_t(r.cap_planes * r.plane_points) * per_point;
        }
        b += sweep_bytes + chunks_.size() * (sizeof(HtChunk) + sizeof(SpilledChunk) + 2 * sizeof(tlod::SectionInfo));
        return b;
    }

    int64_t plan_slab(std::size_t sweep_bytes, std::size_t& planned) {
        const std::size_t budget = o_.memory_bytes > kUnplannedBytes ? o_.memory_bytes - kUnplannedBytes : 0;
        if (o_.slab_planes > 0) {
            planned = planned_bytes(o_.slab_planes, sweep_bytes);
            if (planned <= budget) return o_.slab_planes;
        } else {
            for (int64_t S = 64; S >= 1; S /= 2) {
                planned = planned_bytes(S, sweep_bytes);
                if (planned <= budget) return S;
            }
        }
        const std::size_t need = (planned + kUnplannedBytes + (std::size_t{1} << 20) - 1) >> 20;
        throw Error(ErrorCode::InvalidArgument,
                    "converting this volume plane by plane needs at least " + std::to_string(need) +
                        " MiB with bricks of 2^" + std::to_string(o_.encode.brick_log2 + 1) +
                        " steps (budget " + std::to_string(o_.memory_bytes >> 20) +
                        " MiB): raise the budget (tetlod convert --memory, Python memory_bytes) or lower the brick size (--brick-log2)");
    }

    // ---- pass 2 ----
    void encode_all(HtErrorSweep* sweep, int64_t S) {
        set_up_rows(S);
        for (Rows& r : rows_) {
            r.values.assign(std::size_t(r.cap_planes * r.plane_points), T{});
            if (r.t < d_.k) r.errors.assign(std::size_t(r.cap_planes * r.plane_points), 0.0f);
            reset_window(r);
        }
        const std::size_t plane = planes_.plane_bytes();
        HugePageVector<std::byte> window(std::size_t(S + 2 * kReach) * plane);
        int64_t wz0 = 0, wcount = 0;
        for (int64_t za = 0; za <= zmax_; za += S) {
            const int64_t zb = std::min(za + S - 1, zmax_);
            const int64_t need_lo = std::max<int64_t>(0, za - kReach);
            const int64_t need_hi = std::min(zmax_, zb + kReach);
            if (need_lo > wz0) {
                const int64_t drop = std::min(need_lo - wz0, wcount);
                std::memmove(window.data(), window.data() + std::size_t(drop) * plane,
                             std::size_t(wcount - drop) * plane);
                wcount -= drop;
                wz0 = need_lo;
            }
            if (wz0 + wcount - 1 < need_hi) {
                const int64_t from = wz0 + wcount;
                planes_.read(from, need_hi - from + 1, window.data() + std::size_t(wcount) * plane);
                wcount = need_hi - wz0 + 1;
            }
            const T* w = reinterpret_cast<const T*>(window.data());
            for (Rows& r : rows_) take_values(r, w, wz0, za, zb);
            if (sweep) sweep->process(window.data(), wz0, za, zb, *this);
            else o_.errors->fill(za, zb, *this);
            encode_ready_rows(zb);
            if (o_.progress) o_.progress("encode", uint64_t(zb + 1), uint64_t(zmax_ + 1));
        }
    }

    void reset_window(Rows& r) {
        r.wlo = std::max<int64_t>(0, r.row_lo() - r.h);
        r.window = G_;
        r.window.shift = r.t;
        r.window.origin = {0, 0, r.wlo};
        r.window.nx = r.nx;
        r.window.ny = r.ny;
    }

    /// Copies cycle t's lattice points of planes za..zb into its buffer.
    void take_values(Rows& r, const T* window, int64_t wz0, int64_t za, int64_t zb) {
        for (int64_t z = (za + r.h - 1) / r.h * r.h; z <= zb; z += r.h) {
            const int64_t p = (z - r.wlo) >> r.t;
            if (z < r.wlo || p >= r.cap_planes)
                throw Error(ErrorCode::InvalidArgument, "HT streaming encoder: value plane outside its window");
            const T* src = window + std::size_t((z - wz0) * G_.nx * G_.ny);
            T* dst = r.values.data() + std::size_t(p * r.plane_points);
            if (r.t == 0) {
                std::memcpy(dst, src, std::size_t(r.plane_points) * sizeof(T));
                continue;
            }
            for (int64_t y = 0; y < G_.ny; y += r.h)
                for (int64_t x = 0; x < G_.nx; x += r.h) dst[(y >> r.t) * r.nx + (x >> r.t)] = src[y * G_.nx + x];
        }
    }

    /// A row of cycle t the sweep has passed: its last plane plus 2^t.
    bool row_ready(const Rows& r, int64_t zb) const {
        return r.row < r.nrows && std::min(r.row_hi(zmax_) + r.h, zmax_) <= zb;
    }

    /// Encodes every row the sweep has passed (up to plane zb). The ready rows
    /// of all cycles are coded together, each chunk's field and errors as two
    /// tasks: a small volume has one chunk per cycle, and coding the cycles one
    /// after the other left a core idle. A cycle's next row waits for its
    /// buffer to slide, so rows of one cycle still go one after the other.
    void encode_ready_rows(int64_t zb) {
        std::vector<Rows*> ready;
        for (;;) {
            ready.clear();
            for (Rows& r : rows_)
                if (row_ready(r, zb)) ready.push_back(&r);
            if (ready.empty()) return;
            struct Task {
                std::size_t row;    // in ready
                std::size_t chunk;  // in chunks_
                std::size_t slot;   // in the row
                bool field;
            };
            std::vector<Task> tasks;
            std::vector<std::vector<CodedSection>> fs(ready.size()), es(ready.size());
            for (std::size_t i = 0; i < ready.size(); ++i) {
                const Rows& r = *ready[i];
                const auto nb = G_.bricks(r.t);
                const std::size_t per_row = std::size_t(nb[0] * nb[1]);
                const std::size_t base = first_[std::size_t(r.t)] + std::size_t(r.row) * per_row;
                fs[i].resize(per_row);
                es[i].resize(per_row);
                for (std::size_t j = 0; j < per_row; ++j) {
                    tasks.push_back({i, base + j, j, true});
                    tasks.push_back({i, base + j, j, false});
                }
            }
            const ChunkModeChoice choice = chunk_mode_choice(o_.encode);
            // One task a section (a chunk's coding depends on that chunk alone:
            // the same bytes for any schedule).
            tbb::parallel_for(
                std::size_t(0), tasks.size(),
                [&](std::size_t k) {
                    const Task& task = tasks[k];
                    const Rows& r = *ready[task.row];
                    const HtChunk& c = chunks_[task.chunk];
                    if (task.field)
                        fs[task.row][task.slot] = encode_field_chunk_v3<T>(r.window, r.values.data(), c, choice);
                    else
                        es[task.row][task.slot] = encode_error_chunk_v3<T>(
                            r.window, r.values.data(), std::span<const float>(r.errors), c, m_, choice);
                },
                tbb::simple_partitioner());
            for (std::size_t i = 0; i < ready.size(); ++i) finish_row(*ready[i], fs[i], es[i]);
        }
    }

    /// Spills r's coded row, adds its errors to the summary, slides the buffer.
    void finish_row(Rows& r, std::vector<CodedSection>& fs, std::vector<CodedSection>& es) {
        const std::size_t per_row = fs.size();
        const auto nb = G_.bricks(r.t);
        const std::size_t base = first_[std::size_t(r.t)] + std::size_t(r.row) * std::size_t(nb[0] * nb[1]);
        if (!r.errors.empty()) {
            // The row's errors, plane by plane, at the centres of cycle t only
            // (lattice points not all of whose coordinates are even multiples).
            const int64_t p0 = (r.row_lo() - r.wlo + r.h - 1) >> r.t, p1 = (r.row_hi(zmax_) - r.wlo) >> r.t;
            std::vector<ErrorSummary> sums(std::size_t(p1 - p0 + 1), ErrorSummary(m_));
            tbb::parallel_for(p0, p1 + 1, [&](int64_t p) {
                const float* e = r.errors.data() + std::size_t(p * r.plane_points);
                ErrorSummary& sum = sums[std::size_t(p - p0)];
                const bool z_even = (((r.wlo >> r.t) + p) & 1) == 0;
                for (int64_t yi = 0; yi < r.ny; ++yi) {
                    const float* row = e + yi * r.nx;
                    const int64_t step = z_even && (yi & 1) == 0 ? 2 : 1;
                    for (int64_t xi = step - 1; xi < r.nx; xi += step) sum.add(row[xi]);
                }
            });
            for (const ErrorSummary& sum : sums) errors_.merge(sum);
        }
        for (std::size_t j = 0; j < per_row; ++j) {
            SpilledChunk& s = spilled_[base + j];
            s.field_offset = spill_.size();
            s.field_size = fs[j].bytes.size();
            s.field_raw = fs[j].raw_size;
            s.field_flags = fs[j].flags;
            s.field_checksum = tlod::checksum64(fs[j].bytes);
            spill_.write(fs[j].bytes.data(), fs[j].bytes.size());
            s.error_offset = spill_.size();
            s.error_size = es[j].bytes.size();
            s.error_raw = es[j].raw_size;
            s.error_flags = es[j].flags;
            s.error_checksum = tlod::checksum64(es[j].bytes);
            spill_.write(es[j].bytes.data(), es[j].bytes.size());
        }
        // Slide: the next row's window starts h below it; keep the planes from there.
        const int64_t old = r.wlo;
        ++r.row;
        if (r.row >= r.nrows) {
            r.values = {};
            r.errors = {};
            return;
        }
        reset_window(r);
        const int64_t shift = (r.wlo - old) >> r.t;
        const std::size_t keep = std::size_t((r.cap_planes - shift) * r.plane_points);
        const std::size_t from = std::size_t(shift * r.plane_points);
        std::memmove(r.values.data(), r.values.data() + from, keep * sizeof(T));
        if (!r.errors.empty()) std::memmove(r.errors.data(), r.errors.data() + from, keep * sizeof(float));
    }

    void assemble(const tlod::Metadata& meta) {
        tlod::ContainerWriter w;
        add_ht_leading_sections(w, d_, meta, errors_, o_.encode);
        for (std::size_t i = 0; i < chunks_.size(); ++i) {
            const HtChunk& c = chunks_[i];
            const SpilledChunk& s = spilled_[i];
            w.add_spilled(tlod::kSectionHtField, s.field_flags, uint32_t(c.cycle), c.brick, spill_,
                          s.field_offset, s.field_size, s.field_raw, s.field_checksum);
            w.add_spilled(tlod::kSectionHtErrors, s.error_flags, uint32_t(c.cycle), c.brick, spill_,
                          s.error_offset, s.error_size, s.error_raw, s.error_checksum);
        }
        w.write(path_);
    }

    class SourcePlanes {
    public:
        SourcePlanes(VolumePlanes& s, const HtDomain& d) : box_(s, d), sd_(s.header().dims) {}
        std::size_t plane_bytes() const { return box_.plane_bytes(); }
        void read(int64_t z0, int64_t n, std::byte* dst) { box_.read(z0, n, dst); }
        Dims source_dims() const { return sd_; }
        BoxPlanes& box() { return box_; }

    private:
        BoxPlanes box_;
        Dims sd_;
    };

    HtDomain d_;
    const HtStreamEncodeOptions& o_;
    int m_;
    SourcePlanes planes_;
    Geometry G_;
    std::vector<HtChunk> chunks_;
    std::vector<std::size_t> first_;
    std::string path_;
    SpillFile spill_;
    std::vector<SpilledChunk> spilled_;
    std::vector<Rows> rows_;
    ErrorSummary errors_{m_};
    int64_t zmax_ = 0;
};

}  // namespace

HtStreamEncodeSummary write_ht_container_streaming(VolumePlanes& source, tlod::Metadata meta,
                                                   const std::string& path, const HtStreamEncodeOptions& o) {
    if (o.encode.brick_log2 < 1 || o.encode.brick_log2 > 16)
        throw Error(ErrorCode::InvalidArgument, "brick_log2 must be in 1..16");
    if (o.encode.error_mantissa_bits < 0 || o.encode.error_mantissa_bits > 7)
        throw Error(ErrorCode::InvalidArgument, "error mantissa bits must be in 0..7");
    if (o.slab_planes < 0 || o.slab_planes > 1024)
        throw Error(ErrorCode::InvalidArgument, "slab planes must be in 0..1024");
    const Volume& h = source.header();
    if (h.type != meta.type || !(h.dims == meta.dims))
        throw Error(ErrorCode::InvalidArgument, "metadata does not describe the volume");
    const HtDomain d = HtDomain::for_dims(h.dims, o.pad);
    return dispatch_value_type(h.type, [&](auto tag) {
        using T = decltype(tag);
        StreamEncoder<T> enc(source, d, o, path);
        return enc.run(std::move(meta));
    });
}

}  // namespace tetlod

// ---- Distributed conversion hooks (ht_distributed.hpp) ----

namespace tetlod {

namespace {

int64_t lattice_plane_points(const HtDomain& d, int t) {
    return ((int64_t(d.box_max[0]) >> t) + 1) * ((int64_t(d.box_max[1]) >> t) + 1);
}

int64_t first_multiple(int64_t z, int t) {
    const int64_t h = int64_t{1} << t;
    return (std::max<int64_t>(z, 0) + h - 1) / h * h;
}

int64_t multiples_in(int64_t z1, int64_t z2, int t) {
    const int64_t f = first_multiple(z1, t);
    return z2 >= f ? ((z2 - f) >> t) + 1 : 0;
}

}  // namespace

int64_t ht_lattice_plane_points(const HtDomain& d, int t) { return lattice_plane_points(d, t); }

void ht_lattice_values(VolumePlanes& source, bool pad, int t, int64_t z, std::byte* out) {
    const Volume& h = source.header();
    const HtDomain d = HtDomain::for_dims(h.dims, pad);
    if (t < 0 || t > d.k || z < 0 || z > d.box_max[2] || (z & ((int64_t{1} << t) - 1)))
        throw Error(ErrorCode::InvalidArgument, "ht_lattice_values: not a lattice plane of the cycle");
    BoxPlanes box(source, d);
    std::vector<std::byte> plane(box.plane_bytes());
    box.read(z, 1, plane.data());
    const std::size_t vs = value_size(h.type);
    const int64_t bx = int64_t(d.box_max[0]) + 1, by = int64_t(d.box_max[1]) + 1, step = int64_t{1} << t;
    if (t == 0) {
        std::memcpy(out, plane.data(), plane.size());
        return;
    }
    for (int64_t y = 0; y < by; y += step)
        for (int64_t x = 0; x < bx; x += step) {
            std::memcpy(out, plane.data() + std::size_t(y * bx + x) * vs, vs);
            out += vs;
        }
}

std::array<int64_t, 2> ht_source_planes_for(const HtDomain& d, const Dims& source, int64_t za, int64_t zb) {
    if (za > zb) return {0, -1};
    const int64_t lo = std::max<int64_t>(0, za - HtErrorSweep::kReach);
    const int64_t hi = std::min<int64_t>(d.box_max[2], zb + HtErrorSweep::kReach);
    // BoxPlanes repeats the last source plane beyond the volume (padding).
    return {std::min(lo, source.z - 1), std::min(hi, source.z - 1)};
}

HtScanPart ht_scan_planes(VolumePlanes& source, bool pad, int64_t za, int64_t zb) {
    const Volume& h = source.header();
    const HtDomain d = HtDomain::for_dims(h.dims, pad);
    HtScanPart part;
    if (za > zb) {
        part.coarse.assign(std::size_t(HtErrorSweep::coarse_dims(d).count()) * value_size(h.type), std::byte{0});
        return part;
    }
    if (za < 0 || zb > d.box_max[2]) throw Error(ErrorCode::InvalidArgument, "ht_scan_planes: planes outside B");
    HtStreamEncodeOptions o;
    dispatch_value_type(h.type, [&](auto tag) {
        using T = decltype(tag);
        BoxPlanes box(source, d);
        const Geometry G = geometry_of(d, 4);
        part.coarse = scan_box<T>(box, d, G, h.dims, za, zb, o, d.box_max[2], part.range, part.any);
    });
    return part;
}

void ht_merge_scan(HtScanPart& into, const HtScanPart& next) {
    if (into.coarse.size() != next.coarse.size())
        throw Error(ErrorCode::InvalidArgument, "ht_merge_scan: parts of different volumes");
    // Each coarse point comes from one part, the others hold zero bytes there.
    for (std::size_t i = 0; i < into.coarse.size(); ++i) into.coarse[i] |= next.coarse[i];
    if (!next.any) return;
    if (!into.any) {
        into.range = next.range;
        into.any = true;
        return;
    }
    // As the serial scan: strict comparisons, so the first of equal extremes stays.
    into.range[0] = next.range[0] < into.range[0] ? next.range[0] : into.range[0];
    into.range[1] = next.range[1] > into.range[1] ? next.range[1] : into.range[1];
}

HtRangeErrors::HtRangeErrors(VolumePlanes& source, bool pad, std::array<double, 2> range,
                             std::vector<std::byte> coarse, int64_t za, int64_t zb, int64_t slab_planes)
    : source_(source), d_(HtDomain::for_dims(source.header().dims, pad)), za_(za), zb_(zb),
      slab_(std::max<int64_t>(1, slab_planes)), sweep_(d_, source.header().type, range, std::move(coarse)) {
    if (za <= zb && (za < 0 || zb > d_.box_max[2]))
        throw Error(ErrorCode::InvalidArgument, "HtRangeErrors: planes outside B");
    sweep_.set_partial(true);
    const int k = std::max(0, d_.k);
    planes_.resize(std::size_t(k));
    first_.resize(std::size_t(k));
    for (int t = 0; t < k; ++t) {
        first_[std::size_t(t)] = first_multiple(za, t);
        planes_[std::size_t(t)].assign(std::size_t(multiples_in(za, zb, t) * lattice_plane_points(d_, t)), 0.0f);
    }
}

HtRangeErrors::~HtRangeErrors() = default;

void HtRangeErrors::compute() {
    if (za_ > zb_) return;
    BoxPlanes box(source_, d_);
    const std::size_t plane = box.plane_bytes();
    const int64_t zmax = d_.box_max[2];
    HugePageVector<std::byte> window(std::size_t(slab_ + 2 * kReach) * plane);
    for (int64_t a = za_; a <= zb_; a += slab_) {
        const int64_t b = std::min(a + slab_ - 1, zb_);
        const int64_t lo = std::max<int64_t>(0, a - kReach), hi = std::min(zmax, b + kReach);
        box.read(lo, hi - lo + 1, window.data());
        sweep_.process(window.data(), lo, a, b, *this);
    }
}

void HtRangeErrors::finish() { sweep_.finish_range(za_, zb_, *this); }

float* HtRangeErrors::error_plane(int t, int64_t z) {
    if (t < 0 || t >= int(planes_.size()) || z < first_[std::size_t(t)] || z > zb_ || (z & ((int64_t{1} << t) - 1)))
        throw Error(ErrorCode::InvalidArgument, "HtRangeErrors: error plane outside its planes");
    return planes_[std::size_t(t)].data() +
           std::size_t(((z - first_[std::size_t(t)]) >> t) * lattice_plane_points(d_, t));
}

void HtRangeErrors::pack(int64_t z1, int64_t z2, float* out) const {
    if (z1 > z2) return;
    if (z1 < za_ || z2 > zb_) throw Error(ErrorCode::InvalidArgument, "HtRangeErrors: packing planes it does not hold");
    for (int t = 0; t < int(planes_.size()); ++t) {
        const int64_t n = multiples_in(z1, z2, t), pp = lattice_plane_points(d_, t);
        if (n == 0) continue;
        const int64_t from = (first_multiple(z1, t) - first_[std::size_t(t)]) >> t;
        std::memcpy(out, planes_[std::size_t(t)].data() + std::size_t(from * pp), std::size_t(n * pp) * sizeof(float));
        out += n * pp;
    }
}

std::size_t HtRangeErrors::bytes() const {
    std::size_t b = 0;
    for (const auto& p : planes_) b += p.size() * sizeof(float);
    return b;
}

std::size_t ht_packed_error_floats(const HtDomain& d, int64_t z1, int64_t z2) {
    std::size_t n = 0;
    for (int t = 0; t < d.k; ++t) n += std::size_t(multiples_in(z1, z2, t) * lattice_plane_points(d, t));
    return n;
}

void ht_unpack_errors(const HtDomain& d, int64_t z1, int64_t z2, const float* packed, HtErrorPlaneSink& sink) {
    for (int t = 0; t < d.k; ++t) {
        const int64_t pp = lattice_plane_points(d, t), n = multiples_in(z1, z2, t);
        const int64_t nx = (int64_t(d.box_max[0]) >> t) + 1, ny = (int64_t(d.box_max[1]) >> t) + 1;
        for (int64_t i = 0, z = first_multiple(z1, t); i < n; ++i, z += int64_t{1} << t) {
            // Only the centres of cycle t, as the sweep writes them: the
            // encoder's buffer keeps whatever it holds elsewhere.
            float* out = sink.error_plane(t, z);
            const bool z_even = ((z >> t) & 1) == 0;
            for (int64_t yi = 0; yi < ny; ++yi) {
                const int64_t step = z_even && (yi & 1) == 0 ? 2 : 1;
                for (int64_t xi = step - 1; xi < nx; xi += step) out[yi * nx + xi] = packed[yi * nx + xi];
            }
            packed += pp;
        }
    }
}

}  // namespace tetlod
