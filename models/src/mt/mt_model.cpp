// MtModel: assembly and structural validation of stored parts, and the
// order extraction needs: updates grouped by survivor, sorted by label (CSR).
#include <algorithm>
#include <cmath>
#include <string>

#include "tetlod/models/detail/mt_geometry.hpp"
#include "tetlod/models/mt/mt_model.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/float_bound.hpp"

namespace tetlod {

namespace {
[[noreturn]] void corrupt(const std::string& what) {
    throw Error(ErrorCode::CorruptData, "MT model: " + what);
}

/// Bits [from, from + count) of `src` ORed into `dst` at bit `to` (dst zeroed there).
void copy_bits(const std::vector<uint64_t>& src, uint64_t from, std::vector<uint64_t>& dst, uint64_t to,
               uint64_t count) {
    while (count > 0) {
        const uint64_t take = std::min<uint64_t>({count, 64 - (from & 63), 64 - (to & 63)});
        const uint64_t mask = take == 64 ? ~uint64_t(0) : (uint64_t(1) << take) - 1;
        dst[to >> 6] |= ((src[from >> 6] >> (from & 63)) & mask) << (to & 63);
        from += take, to += take, count -= take;
    }
}
}  // namespace

void MtModel::set_field_error_bound(double e) {
    if (!(e >= 0) || !std::isfinite(e))
        throw Error(ErrorCode::InvalidArgument, "MT model: the field's error bound must be finite and >= 0");
    field_error_bound_ = float_at_least(e);  // rounded up, as HtModel states it
}

MtModel MtModel::from_parts(Volume field, std::vector<std::array<uint32_t, 4>> base_tets,
                            std::vector<MtUpdate> updates, std::vector<uint64_t> mask_bits) {
    validate_dims(field.dims, "MT field");
    if (field.dims.x < 2 || field.dims.y < 2 || field.dims.z < 2 || field.count() >= (int64_t(1) << 31) ||
        field.dims.x > 4096 || field.dims.y > 4096 || field.dims.z > 4096)
        corrupt("unusable dims");
    if (field.data.size() != size_t(field.count()) * value_size(field.type)) corrupt("field size");
    MtModel m;
    m.field_ = std::move(field);
    m.base_ = std::move(base_tets);
    m.updates_ = std::move(updates);
    m.mask_bits_ = std::move(mask_bits);
    m.finalize();
    return m;
}

void MtModel::finalize() {
    const uint64_t n = uint64_t(field_.count());
    const mt::Grid g(field_.dims);
    if (base_.empty()) corrupt("empty base mesh");
    if (base_.size() > 5 * n) corrupt("base mesh larger than the reference mesh");
    std::vector<uint8_t> is_base(n, 0);
    for (const auto& t : base_) {
        for (uint32_t v : t)
            if (v >= n) corrupt("base vertex out of range");
        if (mt::orient(g.coord(t[0]), g.coord(t[1]), g.coord(t[2]), g.coord(t[3])) <= 0)
            corrupt("base tet not positively oriented");
        for (uint32_t v : t) is_base[v] = 1;
    }
    // Pass 1, in the given order: ranges, coverage, and the mask offsets of that order.
    std::vector<uint8_t> inserted(n, 0);
    csr_start_.assign(n + 1, 0);
    const uint64_t total_bits = uint64_t(mask_bits_.size()) * 64;
    uint64_t mask_end = 0;  // masks follow each other in the order of the updates
    mask_start_.clear();
    mask_start_.reserve(updates_.size() / 64 + 1);
    max_label_ = 0;
    for (size_t k = 0; k < updates_.size(); ++k) {
        const MtUpdate& u = updates_[k];
        if (u.w >= n || u.s >= n || u.w == u.s) corrupt("update vertex out of range");
        if (u.label == 0) corrupt("update label 0");
        if (!(u.error >= 0.0f)) corrupt("negative or NaN error");
        if (u.star < 1 || u.star > base_.size() + 5 * n) corrupt("star size out of range");
        if ((k & 63) == 0) mask_start_.push_back(mask_end);
        if (u.star > total_bits - mask_end) corrupt("masks beyond the mask bits");
        mask_end += u.star;
        if (inserted[u.w]) corrupt("grid point inserted twice");
        if (is_base[u.w]) corrupt("base vertex inserted by an update");
        inserted[u.w] = 1;
        ++csr_start_[u.s + 1];
        max_label_ = std::max(max_label_, u.label);
    }
    for (uint64_t p = 0; p < n; ++p)
        if (!is_base[p] && !inserted[p]) corrupt("some grid points are neither base vertices nor inserted");
    std::vector<uint8_t>().swap(is_base);
    std::vector<uint8_t>().swap(inserted);
    // The stored order: by survivor, then label. The updates of a survivor are then a
    // range of updates_ (csr_start_), which spares a 4-byte index per update.
    for (uint64_t p = 0; p < n; ++p) csr_start_[p + 1] += csr_start_[p];
    std::vector<uint32_t> order(updates_.size());  // order[new position] = given position
    {
        std::vector<uint32_t> fill(csr_start_.begin(), csr_start_.end() - 1);
        for (size_t k = 0; k < updates_.size(); ++k) order[fill[updates_[k].s]++] = uint32_t(k);
    }
    for (uint64_t p = 0; p < n; ++p) {
        auto b = order.begin() + csr_start_[p], e = order.begin() + csr_start_[p + 1];
        std::sort(b, e, [&](uint32_t a, uint32_t c) { return updates_[a].label < updates_[c].label; });
        for (auto it = b; it != e; ++it) {
            if (it + 1 != e && updates_[*it].label >= updates_[*(it + 1)].label)
                corrupt("labels do not increase along a survivor");
            if (it + 1 != e && updates_[*it].error > updates_[*(it + 1)].error)
                corrupt("errors not monotone along a survivor");
        }
    }
    // Masks in the new order (offsets of the given order still in mask_start_).
    auto given_offset = [&](size_t k) {
        uint64_t off = mask_start_[k >> 6];
        for (size_t j = k & ~size_t(63); j < k; ++j) off += updates_[j].star;
        return off;
    };
    std::vector<uint64_t> masks((mask_end + 63) / 64, 0);
    std::vector<uint64_t> starts;
    starts.reserve(mask_start_.capacity());
    uint64_t at = 0;
    for (size_t j = 0; j < order.size(); ++j) {
        if ((j & 63) == 0) starts.push_back(at);
        const uint32_t star = updates_[order[j]].star;
        copy_bits(mask_bits_, given_offset(order[j]), masks, at, star);
        at += star;
    }
    mask_bits_ = std::move(masks);
    mask_start_ = std::move(starts);
    if (!history_.empty()) {
        // Collapse k (node n + k) now sits at a new position.
        std::vector<uint32_t>& where = history_.front().update_of_node;
        std::vector<uint32_t> new_pos(order.size());
        for (size_t j = 0; j < order.size(); ++j) new_pos[order[j]] = uint32_t(j);
        for (uint32_t& k : where) k = new_pos[k];
    }
    // The kept records in the new order; the survivor is their group's.
    splits_.clear();
    splits_.reserve(order.size());
    for (const uint32_t k : order) {
        const MtUpdate& u = updates_[k];
        splits_.push_back(MtSplit{u.w, u.label, u.error, u.star});
    }
    std::vector<uint32_t>().swap(order);
    std::vector<MtUpdate>().swap(updates_);
    // The node an update inserts at w must be younger than the update.
    for (const MtSplit& u : splits_) {
        if (csr_start_[u.w + 1] > csr_start_[u.w]) {
            const MtSplit& last = splits_[csr_start_[u.w + 1] - 1];
            if (last.label >= u.label) corrupt("child label not below its parent");
            if (last.error > u.error) corrupt("errors not monotone up the forest");
        }
    }
    range_ = field_.range();
}

uint32_t MtModel::survivor(size_t k) const {
    // The group p holds [csr_start_[p], csr_start_[p + 1]): the last start <= k.
    const auto it = std::upper_bound(csr_start_.begin(), csr_start_.end(), uint32_t(k));
    return uint32_t(it - csr_start_.begin()) - 1;
}

std::size_t MtModel::memory_bytes() const {
    auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
    std::size_t r = sizeof(*this) + bytes(field_.data) + bytes(base_) + bytes(updates_) + bytes(splits_) + bytes(mask_bits_) + bytes(mask_start_) +
                    bytes(csr_start_) + bytes(history_);
    for (const MtHistory& h : history_) {
        for (const auto* lists : {&h.before, &h.after}) {
            r += bytes(*lists);
            for (const auto& tets : *lists) r += bytes(tets);
        }
        r += bytes(h.base) + bytes(h.update_of_node);
    }
    return r;
}

}  // namespace tetlod
