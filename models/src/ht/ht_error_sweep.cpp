// Slab-by-slab diamond errors (see ht_error_sweep.hpp): the evaluators of
// ht_error_builder.hpp over a window of planes.
#include "tetlod/models/ht/ht_error_sweep.hpp"

#include "ht_error_builder.hpp"

namespace tetlod {

using namespace ht;
using namespace ht::error_detail;

struct HtErrorSweep::Impl {
    virtual ~Impl() = default;
    virtual void process(const std::byte* window, int64_t window_z0, int64_t za, int64_t zb,
                         HtErrorPlaneSink& sink) = 0;
    virtual std::size_t memory_bytes() const = 0;
    virtual void set_partial(bool partial) = 0;
    virtual std::vector<std::byte> partial_maxima() const = 0;
    virtual void merge_partial_maxima(const std::byte* other, std::size_t bytes) = 0;
    virtual std::size_t partial_maximum_bytes() const = 0;
    virtual void merge_maxima(const std::byte* in, std::byte* inout, std::size_t bytes) const = 0;
    virtual void finish_range(int64_t za, int64_t zb, HtErrorPlaneSink& sink) = 0;
};

namespace {

template <class T, class Acc>
class Sweep final : public HtErrorSweep::Impl {
public:
    Sweep(const HtDomain& d, double slack, std::vector<std::byte> coarse)
        : dom_(d), slack_(slack), coarse_(std::move(coarse)), cd_(HtErrorSweep::coarse_dims(d)),
          X_(int64_t(d.box_max[0]) + 1), XY_(X_ * (int64_t(d.box_max[1]) + 1)) {
        // Templates hold index offsets only; a builder without data makes them.
        const ErrorBuilder<T, Acc> eb(nullptr, 0, X_, XY_, dom_);
        for (int level = 0; level < dom_.max_level(); ++level) {
            const int t = cycle_of(level);
            if (t <= kFineMaxCycle) templates_.push_back(eb.level_templates(level));
            else templates_.emplace_back();
        }
        // Running maxima of the large diamonds, per cycle on its lattice.
        partial_.resize(std::size_t(std::max(0, dom_.k)));
        next_final_.assign(std::size_t(std::max(0, dom_.k)), 0);
        for (int t = kFineMaxCycle + 1; t < dom_.k; ++t) {
            const std::size_t n = std::size_t(lattice(t, 0)) * std::size_t(lattice(t, 1)) *
                                  std::size_t(lattice(t, 2));
            partial_[std::size_t(t)].assign(n, Acc(0));
        }
    }

    void process(const std::byte* window, int64_t wz0, int64_t za, int64_t zb,
                 HtErrorPlaneSink& sink) override {
        const ErrorBuilder<T, Acc> eb(reinterpret_cast<const T*>(window), wz0, X_, XY_, dom_);
        for (int level = 0; level < dom_.max_level(); ++level) {
            const int t = cycle_of(level);
            const int64_t nx = lattice(t, 0);
            if (t <= kFineMaxCycle) {
                // Whole diamonds: the window reaches kReach >= h beyond the slab.
                const auto& lt = templates_[std::size_t(level)];
                eb.for_level_rows(level, za, zb, [&](int32_t x0, int32_t y, int32_t z, int32_t step, int32_t x1) {
                    float* row = sink.error_plane(t, z) + (y >> t) * nx;
                    eb.errors_along_row(lt, x0, y, z, step, x1,
                                        [&](int32_t x, double err) { row[x >> t] = eb.round_up(err, slack_); });
                });
            } else {
                const int64_t h = int64_t{1} << t;
                eb.for_level_centres(
                    level, za - h, zb + h, [&](const Pt& c) { gather(t, c, za, zb); }, false);
            }
        }
        scan_gathered(eb);
        if (!partial_only_) finish_large(zb, sink);
    }

    void set_partial(bool partial) override { partial_only_ = partial; }

    std::vector<std::byte> partial_maxima() const override {
        std::size_t n = 0;
        for (const auto& p : partial_) n += p.size();
        std::vector<std::byte> out(n * sizeof(Acc));
        std::size_t at = 0;
        for (const auto& p : partial_) {
            if (p.empty()) continue;
            std::memcpy(out.data() + at, p.data(), p.size() * sizeof(Acc));
            at += p.size() * sizeof(Acc);
        }
        return out;
    }

    void merge_partial_maxima(const std::byte* other, std::size_t bytes) override {
        std::size_t n = 0;
        for (const auto& p : partial_) n += p.size();
        if (bytes != n * sizeof(Acc))
            throw Error(ErrorCode::InvalidArgument, "HtErrorSweep: partial maxima of another domain");
        std::size_t at = 0;
        for (auto& p : partial_) {
            merge_maxima(other + at, reinterpret_cast<std::byte*>(p.data()), p.size() * sizeof(Acc));
            at += p.size() * sizeof(Acc);
        }
    }

    std::size_t partial_maximum_bytes() const override { return sizeof(Acc); }

    void merge_maxima(const std::byte* in, std::byte* inout, std::size_t bytes) const override {
        for (std::size_t at = 0; at + sizeof(Acc) <= bytes; at += sizeof(Acc)) {
            Acc theirs, mine;
            std::memcpy(&theirs, in + at, sizeof(Acc));
            std::memcpy(&mine, inout + at, sizeof(Acc));
            // kCrossing (-1) is below every maximum: keep it explicitly.
            if (mine == kCrossing || theirs == kCrossing) mine = kCrossing;
            else if (theirs > mine) mine = theirs;
            std::memcpy(inout + at, &mine, sizeof(Acc));
        }
    }

    void finish_range(int64_t za, int64_t zb, HtErrorPlaneSink& sink) override {
        for (int t = kFineMaxCycle + 1; t < dom_.k; ++t) {
            const int64_t h = int64_t{1} << t;
            for (int64_t z = (std::max<int64_t>(za, 0) + h - 1) / h * h; z <= zb && z <= dom_.box_max[2]; z += h)
                finish_plane(t, z, sink);
        }
    }

    std::size_t memory_bytes() const override {
        std::size_t b = coarse_.size();
        for (const auto& p : partial_) b += p.size() * sizeof(Acc);
        for (const auto& lt : templates_) {
            for (const auto& tp : lt.point_templates) b += tp.entries.size() * sizeof(tp.entries[0]);
            for (const auto* spans : {&lt.span_templates, &lt.boundary_templates})
                for (const auto& st : *spans)
                    b += st.spans.size() * sizeof(st.spans[0]) + st.tets.size() * sizeof(st.tets[0]);
        }
        return b;
    }

private:
    static constexpr int kFineMaxCycle = std::countr_zero(unsigned(HtErrorSweep::kReach));
    static_assert(kFineMaxCycle + 1 == HtErrorSweep::kCoarseShift,
                  "the coarse lattice must hold the vertices of every diamond larger than the reach");
    static constexpr Acc kCrossing = Acc(-1);  // a tet crosses the data box: always split

    int cycle_of(int level) const { return dom_.k - 1 - level / 3; }
    int64_t lattice(int t, int a) const { return (int64_t(dom_.box_max[a]) >> t) + 1; }
    std::size_t slot(int t, const Pt& c) const {
        return std::size_t(((int64_t(c[2]) >> t) * lattice(t, 1) + (int64_t(c[1]) >> t)) * lattice(t, 0) +
                           (int64_t(c[0]) >> t));
    }
    Acc coarse_value(const Pt& p) const {
        const int s = HtErrorSweep::kCoarseShift;
        const int64_t i = ((int64_t(p[2]) >> s) * cd_.y + (int64_t(p[1]) >> s)) * cd_.x + (int64_t(p[0]) >> s);
        T v;
        std::memcpy(&v, coarse_.data() + std::size_t(i) * sizeof(T), sizeof(T));
        return Acc(v);
    }

    /// A piece of a large diamond's tet to scan: a few of its rows in this slab.
    struct RowTask {
        Acc* worst;  // the diamond's running maximum
        Tet tet;
        Acc fv[4];
        int64_t z0, z1;
        Acc result = 0;
    };
    static constexpr int64_t kPlanesPerTask = 4;

    /// Queues rows za..zb of the diamond centred at c, in pieces: the largest
    /// diamonds are few but long to scan, so they are split to feed every core.
    void gather(int t, const Pt& c, int64_t za, int64_t zb) {
        Acc& worst = partial_[std::size_t(t)][slot(t, c)];
        if (worst == kCrossing) return;
        Tet tets[8];
        const int n = diamond_tets(c, classify_centre(c, dom_.k), dom_.L, tets);
        const std::size_t first = tasks_.size();
        for (int i = 0; i < n; ++i) {
            switch (classify_against_data_box(tets[i], dom_.box_max)) {
                case BoxRelation::Outside: break;
                case BoxRelation::Crossing:
                    worst = kCrossing;
                    tasks_.resize(first);
                    return;
                case BoxRelation::Inside: {
                    int64_t lo = tets[i][0][2], hi = lo;
                    for (int v = 1; v < 4; ++v) {
                        lo = std::min<int64_t>(lo, tets[i][v][2]);
                        hi = std::max<int64_t>(hi, tets[i][v][2]);
                    }
                    lo = std::max(lo, za);
                    hi = std::min(hi, zb);
                    for (int64_t z = lo; z <= hi; z += kPlanesPerTask) {
                        RowTask task;
                        task.worst = &worst;
                        task.tet = tets[i];
                        for (int v = 0; v < 4; ++v) task.fv[v] = coarse_value(tets[i][v]);
                        task.z0 = z;
                        task.z1 = std::min(hi, z + kPlanesPerTask - 1);
                        tasks_.push_back(task);
                    }
                    break;
                }
            }
        }
    }

    void scan_gathered(const ErrorBuilder<T, Acc>& eb) {
        tbb::parallel_for(std::size_t(0), tasks_.size(), [&](std::size_t i) {
            RowTask& task = tasks_[i];
            int64_t D = 1;
            task.result = eb.scan_rows(task.tet, task.fv, task.z0, task.z1, D);
        });
        for (const RowTask& task : tasks_) *task.worst = task.result > *task.worst ? task.result : *task.worst;
        tasks_.clear();
    }

    /// Hands over the large diamonds whose planes all lie at or below zb. The
    /// tets of a diamond are congruent (one |D|) and x -> up(x) / D is
    /// monotone, so the maximum of the raw maxima gives the same float as the
    /// maximum over tets of the whole-field scan.
    void finish_large(int64_t zb, HtErrorPlaneSink& sink) {
        const int64_t zmax = dom_.box_max[2];
        for (int t = kFineMaxCycle + 1; t < dom_.k; ++t) {
            const int64_t h = int64_t{1} << t;
            int64_t& z = next_final_[std::size_t(t)];
            for (; z <= zmax && std::min(z + h, zmax) <= zb; z += h) finish_plane(t, z, sink);
        }
    }

    /// The errors of cycle t's large diamonds centred in plane z.
    void finish_plane(int t, int64_t z, HtErrorPlaneSink& sink) const {
        const int64_t h = int64_t{1} << t;
        float* plane = sink.error_plane(t, z);
        const int64_t nx = lattice(t, 0);
        const bool z_even = (z & (2 * h - 1)) == 0;
        for (int64_t y = 0; y <= dom_.box_max[1]; y += h) {
            const bool yz_even = z_even && (y & (2 * h - 1)) == 0;
            for (int64_t x = 0; x <= dom_.box_max[0]; x += h) {
                if (yz_even && (x & (2 * h - 1)) == 0) continue;  // a coarser point
                const Pt c{int32_t(x), int32_t(y), int32_t(z)};
                plane[(y >> t) * nx + (x >> t)] = eb_round(final_error(t, c));
            }
        }
    }

    double final_error(int t, const Pt& c) const {
        const Acc worst = partial_[std::size_t(t)][slot(t, c)];
        if (worst == kCrossing) return std::numeric_limits<double>::infinity();
        Tet tets[8];
        const int n = diamond_tets(c, classify_centre(c, dom_.k), dom_.L, tets);
        for (int i = 0; i < n; ++i) {
            if (classify_against_data_box(tets[i], dom_.box_max) != BoxRelation::Inside) continue;
            const int64_t D = std::abs(orient(tets[i][0], tets[i][1], tets[i][2], tets[i][3]));
            return to_double_up(worst) / double(D);
        }
        return 0.0;  // no tet inside the data box
    }

    float eb_round(double err) const { return ErrorBuilder<T, Acc>::round_up(err, slack_); }

    HtDomain dom_;
    double slack_;
    std::vector<std::byte> coarse_;
    Dims cd_;
    int64_t X_, XY_;
    std::vector<typename ErrorBuilder<T, Acc>::LevelTemplates> templates_;  // per level
    std::vector<std::vector<Acc>> partial_;                                // per cycle
    std::vector<int64_t> next_final_;  // per cycle: the first plane of centres not yet handed over
    std::vector<RowTask> tasks_;       // this slab's rows of large diamonds
    bool partial_only_ = false;        // distributed: large diamonds wait for finish_range
};

}  // namespace

Dims HtErrorSweep::coarse_dims(const HtDomain& d) {
    return Dims{(int64_t(d.box_max[0]) >> kCoarseShift) + 1, (int64_t(d.box_max[1]) >> kCoarseShift) + 1,
                (int64_t(d.box_max[2]) >> kCoarseShift) + 1};
}

HtErrorSweep::HtErrorSweep(const HtDomain& domain, ValueType type, std::array<double, 2> range,
                           std::vector<std::byte> coarse) {
    if (coarse.size() != std::size_t(coarse_dims(domain).count()) * value_size(type))
        throw Error(ErrorCode::InvalidArgument, "HtErrorSweep: the coarse lattice has the wrong size");
    dispatch_value_type(type, [&](auto tag) {
        using T = decltype(tag);
        with_accumulator<T>(domain, range, [&](auto acc, double slack) {
            impl_ = std::make_unique<Sweep<T, decltype(acc)>>(domain, slack, std::move(coarse));
        });
    });
}

HtErrorSweep::~HtErrorSweep() = default;

void HtErrorSweep::process(const std::byte* window, int64_t window_z0, int64_t za, int64_t zb,
                           HtErrorPlaneSink& sink) {
    impl_->process(window, window_z0, za, zb, sink);
}

std::size_t HtErrorSweep::memory_bytes() const { return impl_->memory_bytes(); }

void HtErrorSweep::set_partial(bool partial) { impl_->set_partial(partial); }

std::vector<std::byte> HtErrorSweep::partial_maxima() const { return impl_->partial_maxima(); }

void HtErrorSweep::merge_partial_maxima(const std::byte* other, std::size_t bytes) {
    impl_->merge_partial_maxima(other, bytes);
}

std::size_t HtErrorSweep::partial_maximum_bytes() const { return impl_->partial_maximum_bytes(); }

void HtErrorSweep::merge_maxima(const std::byte* in, std::byte* inout, std::size_t bytes) const {
    impl_->merge_maxima(in, inout, bytes);
}

void HtErrorSweep::finish_range(int64_t za, int64_t zb, HtErrorPlaneSink& sink) {
    impl_->finish_range(za, zb, sink);
}

}  // namespace tetlod
