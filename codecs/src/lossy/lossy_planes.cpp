// The lattice field read plane by plane (see lossy_field.hpp).
#include "tetlod/codecs/lossy_field.hpp"

namespace tetlod {

namespace {

// quantize_samples is a pure function of each sample, so quantizing what each
// read returns gives the same field as quantizing the whole volume, however
// the encoder orders and repeats its reads.
class QuantizedPlanes final : public VolumePlanes {
public:
    QuantizedPlanes(VolumePlanes& source, double max_error) : source_(source), max_error_(max_error) {}
    const Volume& header() const override { return source_.header(); }
    void read(int64_t z0, int64_t count, std::byte* dst) override {
        source_.read(z0, count, dst);
        const Dims& d = source_.header().dims;
        quantize_samples(source_.header().type, dst, std::size_t(count * d.x * d.y), max_error_);
    }

private:
    VolumePlanes& source_;
    double max_error_;
};

}  // namespace

std::unique_ptr<VolumePlanes> quantized_planes(VolumePlanes& source, double max_error) {
    if (!(max_error > 0)) throw Error(ErrorCode::InvalidArgument, "lossy max error must be finite and > 0");
    return std::make_unique<QuantizedPlanes>(source, max_error);
}

}  // namespace tetlod
