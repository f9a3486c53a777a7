#include "tetlod/core/volume_planes.hpp"

#include <cstring>

#include "tetlod/core/error.hpp"

namespace tetlod {

namespace {

class InMemoryPlanes final : public VolumePlanes {
public:
    explicit InMemoryPlanes(const Volume& v) : v_(v) {
        header_.dims = v.dims;
        header_.type = v.type;
        header_.spacing = v.spacing;
        header_.origin = v.origin;
        header_.field_name = v.field_name;
        header_.units = v.units;
        header_.metadata = v.metadata;
    }
    const Volume& header() const override { return header_; }
    void read(int64_t z0, int64_t count, std::byte* dst) override {
        if (z0 < 0 || count < 0 || z0 + count > v_.dims.z)
            throw Error(ErrorCode::InvalidArgument, "planes " + std::to_string(z0) + ".." +
                                                        std::to_string(z0 + count - 1) + " outside the volume");
        const std::size_t plane = std::size_t(v_.dims.x * v_.dims.y) * value_size(v_.type);
        std::memcpy(dst, v_.data.data() + std::size_t(z0) * plane, std::size_t(count) * plane);
    }

private:
    const Volume& v_;
    Volume header_;
};

class Reheaded final : public VolumePlanes {
public:
    Reheaded(std::unique_ptr<VolumePlanes> inner, Volume header)
        : inner_(std::move(inner)), header_(std::move(header)) {
        header_.data = {};
        if (!(header_.dims == inner_->header().dims) || header_.type != inner_->header().type)
            throw Error(ErrorCode::InvalidArgument, "with_header: the header's dims or type differ from the planes'");
    }
    const Volume& header() const override { return header_; }
    void read(int64_t z0, int64_t count, std::byte* dst) override { inner_->read(z0, count, dst); }

private:
    std::unique_ptr<VolumePlanes> inner_;
    Volume header_;
};

class OwningPlanes final : public VolumePlanes {
public:
    explicit OwningPlanes(Volume v) : v_(std::move(v)), view_(v_) {}
    const Volume& header() const override { return view_.header(); }
    void read(int64_t z0, int64_t count, std::byte* dst) override { view_.read(z0, count, dst); }

private:
    Volume v_;
    InMemoryPlanes view_;
};

}  // namespace

std::unique_ptr<VolumePlanes> planes_owning(Volume volume) { return std::make_unique<OwningPlanes>(std::move(volume)); }

std::unique_ptr<VolumePlanes> with_header(std::unique_ptr<VolumePlanes> inner, Volume header) {
    return std::make_unique<Reheaded>(std::move(inner), std::move(header));
}

Volume read_all_planes(VolumePlanes& planes) {
    const Volume& h = planes.header();
    Volume v = Volume::allocate(h.dims, h.type);
    v.spacing = h.spacing;
    v.origin = h.origin;
    v.field_name = h.field_name;
    v.units = h.units;
    v.metadata = h.metadata;
    planes.read(0, h.dims.z, v.data.data());
    return v;
}

std::unique_ptr<VolumePlanes> planes_of(const Volume& volume) { return std::make_unique<InMemoryPlanes>(volume); }

}  // namespace tetlod
