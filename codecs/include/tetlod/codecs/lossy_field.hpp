#pragma once
// Error-bounded lossy archival (spec/tlod-format.md §5.1, format 3.1): the
// field is replaced, sample by sample, by a nearby value on a coarse lattice
// (every sample within E of the original), then coded losslessly as usual;
// the error bounds a reader uses are the stored ones plus E, so level-of-detail
// queries keep honouring their bound against the original data.
#include <array>
#include <cstddef>
#include <memory>
#include <string>

#include "tetlod/core/error.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"

namespace tetlod {

/// Replaces each of `count` samples of `type` at `data` by a value within
/// `max_error` of it (E > 0, finite): integers by the nearest multiple of the
/// odd step 2*floor(E)+1 (clamped to the type; exact integer arithmetic),
/// floats by the nearest multiple of 2E computed in double, kept only when
/// it is provably within E after rounding to the type, else the sample stays.
/// A pure function of each sample, so planes read in any order agree.
void quantize_samples(ValueType type, std::byte* data, std::size_t count, double max_error);

/// quantize_samples over a whole volume, in place.
void quantize_volume(Volume& volume, double max_error);

/// `source`'s planes with quantize_samples applied as they are read (the
/// lattice field of a bounded-memory lossy conversion); `source` must outlive
/// the result.
std::unique_ptr<VolumePlanes> quantized_planes(VolumePlanes& source, double max_error);

/// The bound a lossy container of this type states for a requested E: floats
/// E, integers floor(E) (what their quantizers honour); 0 means lossless.
double stored_max_error(ValueType type, double max_error);

/// Minimum and maximum sample of planes read one after the other (NaNs
/// ignored; {0, 0} when there is none): resolves "P%" before a streaming
/// conversion, at the cost of one more read of the volume.
std::array<double, 2> planes_value_range(VolumePlanes& planes);

/// The bound a reader uses for a stored diamond bound in a lossy file: the
/// float32 at or above stored + E (+inf stays +inf).
float bound_against_original(float stored, double max_error);

/// The field.max_error text: the shortest decimal that reads back as E.
std::string format_max_error(double max_error);
/// Parses field.max_error strictly: a decimal number, finite and > 0
/// (CorruptData otherwise: a hostile value must not weaken every bound).
Expected<double> parse_max_error(const std::string& text);

}  // namespace tetlod
